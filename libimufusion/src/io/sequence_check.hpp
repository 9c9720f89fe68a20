#pragma once
// A full check of a recorded sequence for imufusion-info: the text-side problems of
// load_sequence_index, every depth PNG decoded, an image size the scan's pyramid can hold,
// stream rates and gaps, colour/IMU/ground-truth coverage of the depth frames, and a verdict on
// whether it can be scanned.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "io/sequence_index.hpp"

namespace imufusion::io {

/// A pause in a stream: `length` seconds after the sample stamped `after`.
struct StreamGap {
  double after = 0;
  double length = 0;
};

/// Timing of one stream of timestamps (seconds).
struct StreamTiming {
  std::size_t count = 0;
  double first = 0, last = 0;
  double median_interval = 0;   // seconds; 0 with fewer than 2 samples
  double rate_hz = 0;           // 1 / median_interval
  std::vector<StreamGap> gaps;  // intervals longer than kGapFactor x median, oldest first
};

/// An interval longer than this multiple of the median interval is a gap.
inline constexpr double kGapFactor = 1.5;
/// A ground-truth pose within this many seconds of a depth frame covers it (as TUM's tools).
inline constexpr double kGroundTruthMaxDifference = 0.02;

StreamTiming stream_timing(const std::vector<double>& stamps);

/// Depth frames (stamps in seconds, ascending) inside the span of the IMU samples: those the
/// IMU can aid. 0 means a scan gains nothing from the IMU.
std::size_t frames_within_imu(const std::vector<ImuSample>& imu,
                              const std::vector<double>& depth_stamps);

struct SequenceCheck {
  SequenceIndex index;  // metadata and every problem (text side and image decoding)
  StreamTiming depth, imu;
  std::size_t depth_decoded = 0;             // depth PNGs that decoded with the right size
  double mean_valid_depth_fraction = 0;      // over decoded frames: pixels with depth > 0
  std::size_t color_decoded = 0;             // colour images that decoded with the depth size
  std::size_t color_matched = 0;             // depth frames with an associated colour frame
  std::size_t frames_without_imu = 0;        // frames after the first with no sample in (prev, t]
  bool imu_spans_frames = false;             // first IMU stamp <= first depth, last >= last depth
  std::size_t frames_within_imu = 0;         // depth frames inside the IMU's span
  std::size_t frames_with_ground_truth = 0;  // a pose within kGroundTruthMaxDifference
  bool ground_truth_spans_frames = false;    // first and last depth stamp inside the GT span
  /// Things that do not prevent a scan but may spoil it, one sentence each.
  std::vector<std::string> warnings;
  /// False when a scan cannot run: any problem (an image too small for the pyramid among them),
  /// or no intrinsics.
  bool scannable = false;
};

/// Runs every check. `progress(done, total)` is called after each decoded image (depth first,
/// then colour).
SequenceCheck check_sequence(const std::filesystem::path& directory,
                             const std::function<void(std::size_t, std::size_t)>& progress);

}  // namespace imufusion::io
