#pragma once
// imufusion-scan --frame-step N: every Nth depth frame of the input (frames 0, N, 2N, ...), a
// recording made into one with N times faster motion. The IMU stream is not decimated: the
// samples of the skipped frames go with the next kept frame, so the scanner still integrates
// every sample; colour stays with its own (kept) frame.

#include <algorithm>
#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/source.hpp"

namespace imufusion::tools {

/// The kept frames of a sequence (read directly: skipped frames are never decoded) or of a frame
/// source (skipped frames are read and dropped, their IMU samples kept).
class SteppedFrames {
 public:
  /// `step` >= 1; exactly one of `reader` and `source` is non-null and outlives this object.
  SteppedFrames(SequenceReader* reader, FrameSource* source, std::size_t step)
      : reader_(reader), source_(source), step_(std::max<std::size_t>(step, 1)) {}

  /// Kept frames of an input of `frames` frames: ceil(frames / step).
  std::size_t kept_of(std::size_t frames) const { return (frames + step_ - 1) / step_; }

  /// Skips the kept frames at or before `t` (s): those a resumed scan holds already. Sequences
  /// only (a live source's frames are all new); returns how many.
  std::size_t skip_through(double t) {
    std::size_t skipped = 0;
    while (reader_ != nullptr && kept_ * step_ < reader_->frame_count() &&
           reader_->info().depth[kept_ * step_].timestamp <= t) {
      ++kept_;
      ++skipped;
    }
    return skipped;
  }

  /// The next kept frame, nullopt past the end of the input. Its `imu` holds every sample after
  /// the previous kept frame's timestamp up to its own (for the first kept frame, what the input
  /// gives frame 0). Samples after the last kept frame have no frame to go with and are dropped.
  Result<std::optional<Frame>> next() {
    return reader_ != nullptr ? next_from_reader() : next_from_source();
  }

 private:
  Result<std::optional<Frame>> next_from_reader() {
    const std::size_t index = kept_ * step_;
    if (index >= reader_->frame_count()) return std::optional<Frame>{};
    auto frame = reader_->frame(index);
    ++kept_;
    if (!frame) return frame.error();
    if (index > 0 && step_ > 1) {
      frame->imu =
          reader_->imu_between(reader_->info().depth[index - step_].timestamp, frame->timestamp);
    }
    return std::optional<Frame>(std::move(*frame));
  }

  Result<std::optional<Frame>> next_from_source() {
    std::vector<ImuSample> skipped;
    const std::size_t skip = kept_ == 0 ? 0 : step_ - 1;
    for (std::size_t i = 0; i < skip; ++i) {
      auto frame = source_->next();
      if (!frame) return frame.error();
      if (!*frame) return std::optional<Frame>{};
      skipped.insert(skipped.end(), (*frame)->imu.begin(), (*frame)->imu.end());
    }
    auto frame = source_->next();
    if (!frame) return frame.error();
    if (!*frame) return std::optional<Frame>{};
    ++kept_;
    std::vector<ImuSample>& imu = (*frame)->imu;
    imu.insert(imu.begin(), skipped.begin(), skipped.end());
    return frame;
  }

  SequenceReader* reader_;
  FrameSource* source_;
  std::size_t step_;
  std::size_t kept_ = 0;  // kept frames handed out so far
};

}  // namespace imufusion::tools
