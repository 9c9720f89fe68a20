#pragma once
// One interface for every depth input a scanner reads: a recorded sequence directory, a live
// OpenNI2 camera (`openni2://` for the first device, `openni2://URI` for a given one) and an
// OpenNI2 recording (`FILE.oni`). Sources hand out Frames (sequence.hpp) with timestamps in
// seconds: the sequence's own clock for sequences, the recorded device timestamps
// (microseconds) as seconds for .oni recordings, the host clock (host_clock_now() of
// imu_stream.hpp) for live cameras. A .oni recording plays every depth frame in file order,
// each with the recorded colour frame nearest to it in time.

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "imufusion/result.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// A depth stream mode: width x height pixels at fps frames per second.
struct DepthMode {
  int width = 640, height = 480, fps = 30;
};

/// Parses "WxH@FPS" (e.g. "640x480@30", "320x240@60"); kInvalidArgument naming the text
/// otherwise.
Result<DepthMode> parse_depth_mode(std::string_view text);

struct SourceOptions {
  /// Live cameras: the depth mode requested (kUnsupported, listing the device's modes, when
  /// the device has no such mode). Ignored by recordings, which keep their own.
  DepthMode depth_mode;
  /// Colour frames, registered to depth when the device can; off saves bandwidth and decoding.
  bool color = true;
  /// Recordings (sequence, .oni): deliver frames at their recorded pace instead of as fast as
  /// next() is called. No frame is dropped: frames taken late are handed out at once.
  bool realtime = false;
  /// OpenNI2 cameras and recordings: depth intrinsics (pixels) to use instead of those derived
  /// from the stream's fields of view with the principal point at the image centre; needed
  /// for a device that reports no field of view, better for any calibrated camera. width and
  /// height are ignored (the stream's are used).
  std::optional<Intrinsics> intrinsics;
  /// Seconds without a depth frame after which next() reports a live camera lost, or an .oni
  /// recording truncated.
  double frame_timeout = 2.0;
  /// Sequence directories: passed to SequenceReader::open (colour loading follows `color`).
  SequenceOptions sequence;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// The next frame; nullopt at the end of a recording. An error is final (device lost, a
  /// corrupt file): a scanner stops cleanly on it.
  virtual Result<std::optional<Frame>> next() = 0;
  /// Depth intrinsics (pixels), width and height set.
  virtual const Intrinsics& intrinsics() const = 0;
  /// True for a camera (frames come at the device's pace and cannot be replayed).
  virtual bool live() const = 0;
  /// For messages: "sequence DIR", "openni2://URI (DEVICE NAME)", "FILE.oni".
  virtual std::string description() const = 0;
  /// imu_to_camera of a sequence that has one; nullopt when the source does not know it.
  virtual std::optional<Eigen::Isometry3d> T_camera_imu() const { return std::nullopt; }
};

/// Opens `input`: `openni2://` or `openni2://URI`, a path ending in `.oni`, or else a sequence
/// directory. Errors: kNotFound (no such file or directory), kNoDevice (no camera connected,
/// or no driver), kUnsupported (a mode the camera lacks; OpenNI2 input in a build without
/// OpenNI2), kParseError / kIoError (a corrupt recording), each naming the input.
Result<std::unique_ptr<FrameSource>> open_frame_source(std::string_view input,
                                                       const SourceOptions& options = {});

/// True when this build of imufusion reads OpenNI2 cameras and .oni files.
bool openni2_available();

}  // namespace imufusion
