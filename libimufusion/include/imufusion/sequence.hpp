#pragma once
// Reading and writing a recorded sequence in the layout of FORMAT.md (TUM RGB-D directories with
// an IMU stream and calibration in the ETH3D style).
//
// SequenceReader streams: open() parses and checks every text file (index files, IMU,
// calibration, ground truth: they are small) and checks that every listed image exists, but
// decodes no image (it reads only the first depth PNG's 33-byte header, for the image size);
// next() / frame(i) decode one frame's images on demand, so a 10 000-frame sequence never holds
// more than one frame's images in memory. imu.txt and accelerometer.txt are loaded whole at open
// (an ImuSample is 56 bytes: a 200 Hz stream costs about 40 MB per hour of recording).

#include <cstddef>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "imufusion/imu_stream.hpp"
#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// One reading of the TUM benchmark's Kinect accelerometer (accelerometer.txt), m/s^2.
struct AccelerometerSample {
  double timestamp = 0;  // seconds
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();
};

/// One line of depth.txt or rgb.txt.
struct ImageIndexEntry {
  double timestamp = 0;        // seconds
  std::string name;            // as written in the index, relative to the sequence directory
  std::filesystem::path path;  // the sequence directory joined with `name`
};

/// Everything a sequence says about itself, parsed at open.
struct SequenceInfo {
  std::filesystem::path directory;
  /// info.txt, key -> rest of the line (e.g. "gyro_bias" -> "0.01 -0.01 0.02").
  std::map<std::string, std::string> info;
  double depth_scale = 5000.0;  // raw depth units per metre (info.txt `depth_scale`)
  int width = 0, height = 0;    // depth image size: info.txt, else the first depth PNG's header

  /// calibration.txt, or the caller's SequenceOptions::intrinsics; width/height filled in.
  std::optional<Intrinsics> intrinsics;
  bool intrinsics_from_file = false;

  /// imu_to_camera.txt: maps IMU-frame coordinates into the camera frame. Identity when absent.
  Eigen::Isometry3d T_camera_imu = Eigen::Isometry3d::Identity();
  bool has_imu_to_camera = false;

  std::vector<ImageIndexEntry> depth;  // depth.txt, strictly increasing timestamps
  std::vector<ImageIndexEntry> color;  // rgb.txt (empty when absent)
  /// For each depth frame, the index into `color` of its associated colour frame, or -1.
  std::vector<int> color_of_depth;

  Trajectory ground_truth;  // groundtruth.txt (empty when absent)
  bool has_ground_truth = false;
  std::vector<ImuSample> imu;  // imu.txt (empty when absent), without the rejected samples
  bool has_imu = false;
  std::size_t imu_implausible = 0;  // imu.txt samples beyond SequenceOptions::imu_limits
  std::size_t imu_time_jumps = 0;   // imu.txt samples rejected as jumps in time
  std::vector<AccelerometerSample> accelerometer;  // accelerometer.txt (empty when absent)
};

struct SequenceOptions {
  /// Depth and colour frames are paired one-to-one, closest stamps first, when their stamps
  /// differ by less than this (seconds); as TUM's associate.py (--max_difference 0.02).
  double max_color_time_difference = 0.02;
  /// Decode the associated colour image in next() / frame(). Off saves a JPEG decode per frame
  /// for a caller that only needs depth.
  bool load_color = true;
  /// Frame 0 receives the IMU samples with timestamp in (t0 - lookback, t0] (seconds).
  double first_frame_imu_lookback = std::numeric_limits<double>::infinity();
  /// Intrinsics to use instead of calibration.txt (required when the file is absent). width and
  /// height are ignored: they are taken from the images.
  std::optional<Intrinsics> intrinsics;
  /// imu.txt samples beyond these, or jumping in time, are left out (counted in SequenceInfo).
  ImuSampleLimits imu_limits;
};

/// One depth frame with what belongs to it.
struct Frame {
  std::size_t index = 0;
  double timestamp = 0;  // depth timestamp, seconds
  DepthImage depth;
  std::optional<ColorImage> color;  // the associated colour image, when there is one (and loaded)
  double color_timestamp = 0;       // its timestamp, when `color` is set
  /// IMU samples with timestamp in (previous depth timestamp, timestamp]; for frame 0 see
  /// SequenceOptions::first_frame_imu_lookback. Oldest first.
  std::vector<ImuSample> imu;
};

class SequenceReader {
 public:
  /// Parses and checks the sequence in `directory`. Fails, naming file, line and value, on: a
  /// missing directory or depth.txt; a malformed line (field count, a non-number, NaN/inf); a
  /// timestamp that is not strictly after the previous one in any stream; a listed image that
  /// does not exist; non-positive intrinsics or depth_scale; a non-unit quaternion; info.txt
  /// width/height that disagree with the first depth PNG. When several problems exist the
  /// message gives the first and counts the rest.
  static Result<SequenceReader> open(const std::filesystem::path& directory,
                                     const SequenceOptions& options = {});

  SequenceReader(SequenceReader&&) noexcept;
  SequenceReader& operator=(SequenceReader&&) noexcept;
  ~SequenceReader();

  const SequenceInfo& info() const;
  std::size_t frame_count() const;
  /// Depth timestamps, seconds.
  std::vector<double> timestamps() const;
  const std::optional<Intrinsics>& intrinsics() const;
  const Eigen::Isometry3d& T_camera_imu() const;
  bool has_ground_truth() const;
  const Trajectory& ground_truth() const;
  bool has_imu() const;
  const std::vector<ImuSample>& imu() const;
  /// The IMU samples with timestamps in (from, to] (seconds), as frame() gives each frame those
  /// since the frame before it.
  std::vector<ImuSample> imu_between(double from, double to) const;

  /// Decodes frame `index`. Fails, naming the file, on an unreadable, truncated or corrupt image,
  /// a depth PNG that is not 16-bit grayscale, a depth size different from the sequence's, or a
  /// colour size different from the depth size. Does not move the cursor of next().
  Result<Frame> frame(std::size_t index) const;

  /// The frame at the cursor, then advances the cursor, also when the frame fails to decode (so a
  /// caller may skip a bad frame). kInvalidArgument after the last frame.
  Result<Frame> next();
  bool done() const;
  /// Sets the cursor of next() (index <= frame_count()).
  void seek(std::size_t index);

 private:
  struct State;
  explicit SequenceReader(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

/// Writes a sequence in the FORMAT.md layout. Images go to disk as they are added (depth/ and
/// rgb/, PNG, named by timestamp); index and text files are written atomically by finish(). A
/// writer destroyed without finish() leaves images but no index files, unless write_as_you_go.
class SequenceWriter {
 public:
  struct Options {
    /// Allow a directory that already has content; files of the same name are replaced.
    bool allow_existing = false;
    /// Append each index line (depth.txt, rgb.txt, imu.txt) as its image or sample is added,
    /// flushed, and write calibration.txt, imu_to_camera.txt and info.txt as soon as they are
    /// known: a writer that never reaches finish() (a killed process, a full disk) leaves a
    /// sequence readable up to its last complete frame. finish() still rewrites every file.
    bool write_as_you_go = false;
  };

  /// Creates `directory` (and parents). Fails when it exists and is not empty, unless allowed.
  static Result<SequenceWriter> create(const std::filesystem::path& directory,
                                       const Options& options);
  static Result<SequenceWriter> create(const std::filesystem::path& directory);

  SequenceWriter(SequenceWriter&&) noexcept;
  SequenceWriter& operator=(SequenceWriter&&) noexcept;
  ~SequenceWriter();

  /// Writes depth/<timestamp>.png. Timestamps (seconds) must increase strictly, all images must
  /// have the size and depth_scale of the first.
  Status add_depth(double timestamp, const DepthImage& image);
  /// Writes rgb/<timestamp>.png; same size as the depth images.
  Status add_color(double timestamp, const ColorImage& image);
  /// Timestamps must increase strictly.
  Status add_imu(const ImuSample& sample);
  /// Forgets the IMU samples added so far and stops appending to imu.txt: finish() writes only
  /// those added after (e.g. the session's samples again, on a corrected clock).
  void forget_imu();
  /// Timestamps must increase strictly.
  Status add_ground_truth(const StampedPose& pose);
  /// calibration.txt (fx fy cx cy must be positive).
  Status set_intrinsics(const Intrinsics& intrinsics);
  /// imu_to_camera.txt (maps IMU-frame coordinates into the camera frame).
  Status set_T_camera_imu(const Eigen::Isometry3d& T_camera_imu);
  /// An info.txt line. depth_scale, width and height are written from the depth images; setting
  /// them to other values is an error at finish(). Keys hold no whitespace, values no newline.
  Status set_info(const std::string& key, const std::string& value);

  /// Writes depth.txt, rgb.txt, imu.txt, groundtruth.txt, calibration.txt, imu_to_camera.txt
  /// and info.txt (each only when it has content; depth.txt always). Fails when no depth frame
  /// was added.
  Status finish();

  const std::filesystem::path& directory() const;

 private:
  struct State;
  explicit SequenceWriter(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace imufusion
