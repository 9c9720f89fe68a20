// Writes a whole synthetic sequence (FORMAT.md layout) through SequenceWriter.

#include <cmath>
#include <cstdio>
#include <string>
#include <system_error>

#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "synth/random.hpp"

namespace imufusion::synth {

namespace {

namespace fs = std::filesystem;

// IMU samples start this long before the first depth frame and end this long after the last.
constexpr double kImuMargin = 0.1;  // seconds

std::string format_number(double value, int decimals = 9) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

std::string format_vector(const Eigen::Vector3d& v) {
  return format_number(v.x()) + " " + format_number(v.y()) + " " + format_number(v.z());
}

Status check_config(const SynthConfig& c) {
  auto bad = [](const std::string& what) {
    return make_error(ErrorCode::kInvalidArgument, "synthesize: " + what);
  };
  if (c.width < 8 || c.height < 8 || c.width > 8192 || c.height > 8192) {
    return bad("image size " + std::to_string(c.width) + "x" + std::to_string(c.height) +
               " is outside 8..8192");
  }
  if (c.frames < 1) return bad("frames " + std::to_string(c.frames) + " must be at least 1");
  if (!(c.fps > 0.0) || !std::isfinite(c.fps)) return bad("fps " + format_number(c.fps, 3));
  if (!(c.imu_rate > 0.0) || !std::isfinite(c.imu_rate)) {
    return bad("imu_rate " + format_number(c.imu_rate, 3));
  }
  if (!(c.gyro_noise_density >= 0.0) || !(c.accel_noise_density >= 0.0)) {
    return bad("noise densities must be non-negative");
  }
  if (!std::isfinite(c.start_time)) return bad("start_time is not finite");
  return {};
}

/// Whole microseconds, the precision of the text files, so a stamp reads back exactly as the
/// time the frame was rendered at.
double frame_time(const SynthConfig& c, int index) {
  return std::round((c.start_time + index / c.fps) * 1e6) / 1e6;
}

/// info.txt's depth_noise_model: "disparity" (the Kinect model: correlated over the window,
/// disparity steps), "white" (independent per pixel) or "tof".
const char* depth_noise_model(const SynthConfig& config) {
  if (config.sensor == SensorKind::kPhoneToF) return "tof";
  return config.white_depth_noise ? "white" : "disparity";
}

Status write_into(const SynthConfig& config, const fs::path& directory, SynthSummary& summary) {
  Result<SequenceWriter> created = SequenceWriter::create(directory);
  if (!created.ok()) return created.error();
  SequenceWriter& writer = created.value();

  const Scene scene = make_scene(config.scene, config.seed);
  const CameraMotion motion(config.scene, config.seed, config.start_time);
  const Intrinsics intrinsics = default_intrinsics(config.width, config.height);
  SensorModel model = sensor_model(config.sensor);
  model.depth_noise = config.depth_noise;
  if (config.white_depth_noise) model = white_noise_model(model);

  for (int i = 0; i < config.frames; ++i) {
    const double t = frame_time(config, i);
    const Eigen::Isometry3d T_world_camera = motion.pose_at(t);
    const RenderedFrame frame =
        render_frame(scene, T_world_camera, intrinsics, model,
                     mix_seed(config.seed, 1000 + static_cast<std::uint64_t>(i)), config.color);
    IMUFUSION_RETURN_IF_ERROR(writer.add_depth(t, frame.depth));
    if (config.color) IMUFUSION_RETURN_IF_ERROR(writer.add_color(t, frame.color));
    IMUFUSION_RETURN_IF_ERROR(writer.add_ground_truth(StampedPose{t, T_world_camera}));
  }

  ImuConfig imu;
  imu.rate_hz = config.imu_rate;
  imu.gyro_noise_density = config.gyro_noise_density;
  imu.accel_noise_density = config.accel_noise_density;
  imu.noise = config.imu_noise;
  imu.bias = config.imu_noise;
  const ImuBias bias = config.imu_noise ? draw_imu_bias(config.seed) : ImuBias{};
  const double t_first = frame_time(config, 0);
  const double t_last = frame_time(config, config.frames - 1);
  const std::vector<ImuSample> samples =
      generate_imu(motion, imu, bias, t_first - kImuMargin, t_last + kImuMargin, config.seed);
  for (const ImuSample& s : samples) IMUFUSION_RETURN_IF_ERROR(writer.add_imu(s));

  IMUFUSION_RETURN_IF_ERROR(writer.set_intrinsics(intrinsics));
  IMUFUSION_RETURN_IF_ERROR(writer.set_T_camera_imu(imu.T_camera_imu));
  const double gyro_density = config.imu_noise ? config.gyro_noise_density : 0.0;
  const double accel_density = config.imu_noise ? config.accel_noise_density : 0.0;
  const std::pair<std::string, std::string> info[] = {
      {"scene", to_string(config.scene)},
      {"seed", std::to_string(config.seed)},
      {"fps", format_number(config.fps, 6)},
      {"frames", std::to_string(config.frames)},
      {"imu_rate", format_number(config.imu_rate, 6)},
      {"gyro_bias", format_vector(bias.gyro)},
      {"accel_bias", format_vector(bias.accel)},
      {"gyro_noise_density", format_number(gyro_density)},
      {"accel_noise_density", format_number(accel_density)},
      {"depth_noise", config.depth_noise ? "1" : "0"},
      {"depth_noise_model", depth_noise_model(config)},
      {"world_frame", "z_up_metres"},
      {"source", "imufusion-synth"},
  };
  for (const auto& [key, value] : info) IMUFUSION_RETURN_IF_ERROR(writer.set_info(key, value));
  // Kinect sequences keep the lines they always had.
  if (config.sensor != SensorKind::kKinect) {
    IMUFUSION_RETURN_IF_ERROR(writer.set_info("sensor", to_string(config.sensor)));
  }
  if (const std::optional<TimeSpan> stretch = motion.wall_stretch()) {
    IMUFUSION_RETURN_IF_ERROR(writer.set_info(
        "wall_stretch", format_number(stretch->begin, 6) + " " + format_number(stretch->end, 6)));
  }
  IMUFUSION_RETURN_IF_ERROR(writer.finish());

  summary.frames = config.frames;
  summary.duration = t_last - t_first;
  summary.width = config.width;
  summary.height = config.height;
  summary.imu_samples = samples.size();
  summary.bias = bias;
  summary.wall_stretch = motion.wall_stretch();
  return {};
}

Error io_error(const std::string& what, const fs::path& path, const std::error_code& ec) {
  return make_error(ErrorCode::kIoError, what + " " + path.string() + ": " + ec.message());
}

}  // namespace

Result<SynthSummary> synthesize(const SynthConfig& config, const fs::path& requested_dir) {
  IMUFUSION_RETURN_IF_ERROR(check_config(config));
  // "out/" names the directory "out"; the partial sibling must sit next to it, not inside.
  fs::path out_dir = requested_dir.lexically_normal();
  if (!out_dir.has_filename()) out_dir = out_dir.parent_path();
  if (out_dir.empty() || out_dir.filename() == "." || out_dir.filename() == "..") {
    return make_error(ErrorCode::kInvalidArgument,
                      "synthesize: output directory '" + requested_dir.string() +
                          "' must name a directory (not empty, '.' or '..')");
  }
  std::error_code ec;
  const bool exists = fs::exists(out_dir, ec);
  if (exists && !fs::is_directory(out_dir, ec)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "synthesize: " + out_dir.string() + " exists and is not a directory");
  }
  if (exists && !fs::is_empty(out_dir, ec) && !config.overwrite) {
    return make_error(ErrorCode::kInvalidArgument,
                      "synthesize: " + out_dir.string() + " is not empty (overwrite not set)");
  }

  // Build in a sibling "<out_dir>.partial" and rename at the end: a crash leaves no
  // complete-looking sequence at out_dir. A stale partial directory is our own leftover.
  fs::path partial = out_dir;
  partial += ".partial";
  fs::remove_all(partial, ec);
  if (ec) return io_error("cannot remove stale", partial, ec);

  SynthSummary summary;
  if (Status written = write_into(config, partial, summary); !written.ok()) {
    fs::remove_all(partial, ec);
    return written.error();
  }
  if (exists) {
    fs::remove_all(out_dir, ec);
    if (ec) return io_error("cannot replace", out_dir, ec);
  }
  fs::rename(partial, out_dir, ec);
  if (ec) return io_error("cannot rename " + partial.string() + " to", out_dir, ec);
  return summary;
}

}  // namespace imufusion::synth
