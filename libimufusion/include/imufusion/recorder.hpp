#pragma once
// Recording a live session to disk in the sequence format (FORMAT.md), without ever stalling the
// scan: frames go through a bounded queue to a worker thread that encodes and writes them with
// SequenceWriter. When the disk cannot keep up the queue fills and further frames are dropped
// (counted), never waited for.

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

struct RecorderOptions {
  /// Frames waiting for the worker; a 640x480 depth + colour frame is ~1.5 MB, so the default
  /// holds ~2 s at 30 Hz in ~90 MB.
  std::size_t max_queued_frames = 60;
  /// Passed to SequenceWriter::create (e.g. allow_existing).
  SequenceWriter::Options writer;
};

struct RecorderStats {
  std::size_t frames_queued = 0;   // accepted by push_frame
  std::size_t frames_written = 0;  // on disk
  std::size_t frames_dropped = 0;  // refused because the queue was full, or after a write error
  std::size_t imu_samples = 0;     // accepted by push_imu
  std::size_t imu_dropped = 0;     // not after the previous sample (out of order), not finite
};

/// Writes a live session as it goes (worker thread): each frame's depth and colour PNGs, then
/// their depth.txt and rgb.txt lines and the IMU samples pushed before the frame (imu.txt),
/// appended and flushed; calibration.txt, imu_to_camera.txt and info.txt with the first frame.
/// A recording that never reaches finish() (killed, disk full) is readable up to its last
/// complete frame. finish() rewrites imu.txt on the final clock offset. Move-only.
class SessionRecorder {
 public:
  /// Creates the directory (SequenceWriter::create) and starts the worker.
  static Result<SessionRecorder> create(const std::filesystem::path& directory,
                                        const RecorderOptions& options = {});

  SessionRecorder(SessionRecorder&&) noexcept;
  SessionRecorder& operator=(SessionRecorder&&) noexcept;
  ~SessionRecorder();

  /// Queues the frame's depth and colour (Frame::imu is ignored: IMU goes through push_imu).
  /// Returns false, counting a drop, when the queue is full or a write already failed; never
  /// blocks beyond a short mutex hold. Timestamps (host clock, seconds) must increase.
  bool push_frame(Frame frame);
  /// IMU samples on the IMU's own clock; finish() writes them shifted by the clock offset.
  void push_imu(const std::vector<ImuSample>& samples);
  /// t_host = t_imu + offset (seconds), e.g. ClockOffsetEstimate::offset: applied to the
  /// samples pushed after it as they are written; the latest value set before finish() is
  /// applied to all of imu.txt and written to info.txt (`imu_clock_offset`).
  void set_imu_clock_offset(double offset);
  /// calibration.txt.
  void set_intrinsics(const Intrinsics& intrinsics);
  /// imu_to_camera.txt (maps IMU-frame coordinates into the camera frame), when known.
  void set_T_camera_imu(const Eigen::Isometry3d& T_camera_imu);
  /// An info.txt line (see SequenceWriter::set_info).
  void set_info(const std::string& key, const std::string& value);

  /// The first write error so far, if any (the worker stops writing after it).
  Status status() const;
  RecorderStats stats() const;
  const std::filesystem::path& directory() const;

  /// Waits for the queue to drain, writes the text files and returns the first error of the
  /// whole session (a failed image write, a rejected timestamp, or the index files). A
  /// second call returns the same status.
  Status finish();

 private:
  struct State;
  explicit SessionRecorder(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace imufusion
