// imufusion-synth: renders a synthetic RGB-D + IMU sequence with ground truth (FORMAT.md layout).
// Exit status: 0 written, 1 failed while writing, 2 usage error.

#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "imufusion/synth.hpp"

namespace {

using imufusion::synth::SynthConfig;

constexpr const char* kUsage =
    "usage: imufusion-synth --scene room|wall|fast --out DIR [--seed N] [--frames N]\n"
    "                       [--size WxH] [--fps F] [--sensor kinect|phone-tof] [--no-color]\n"
    "                       [--no-noise] [--white-noise] [--overwrite]\n"
    "  --scene      room: furnished room; wall: ~2 s facing a bare wall at 1 m while moving;\n"
    "               fast: bursts of ~90 deg/s rotation\n"
    "  --out        output directory (must be empty or absent unless --overwrite)\n"
    "  --seed       random seed (default 1); the same seed gives identical files\n"
    "  --frames     number of depth frames (default 300)\n"
    "  --size       image size (default: the sensor's, 640x480 or 240x180; intrinsics scale\n"
    "               with it)\n"
    "  --fps        depth frame rate (default: the sensor's, 30)\n"
    "  --sensor     depth sensor model: kinect (default; Kinect v1 structured light, 0.4-4.5 m)\n"
    "               or phone-tof (a phone time-of-flight module: 240x180, 0.2-4 m, noise ~1%\n"
    "               of depth, flying pixels at depth edges, millimetre steps)\n"
    "  --no-color   write no rgb/ images\n"
    "  --no-noise   no depth noise, no IMU noise or bias\n"
    "  --white-noise  kinect: independent depth noise per pixel, 0.2 mm steps (default: the\n"
    "               error of a disparity shared over a 9 px window, in 1/8 px steps)\n";

int usage_error(const std::string& message) {
  std::fprintf(stderr, "imufusion-synth: %s\n%s", message.c_str(), kUsage);
  return 2;
}

template <typename T>
bool parse_number(std::string_view text, T& value) {
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  return ec == std::errc() && ptr == end;
}

bool parse_size(std::string_view text, int& width, int& height) {
  const std::size_t x = text.find('x');
  if (x == std::string_view::npos) return false;
  return parse_number(text.substr(0, x), width) && parse_number(text.substr(x + 1), height);
}

struct Options {
  SynthConfig config;
  std::string out;
  bool have_scene = false, have_size = false, have_fps = false;
};

// Option `arg` with its `value` into `opt`; returns the usage error, empty when taken.
std::string parse_value(std::string_view arg, std::string_view value, Options& opt) {
  SynthConfig& config = opt.config;
  const std::string bad = "bad value '" + std::string(value) + "' for " + std::string(arg);
  if (arg == "--scene") {
    const auto kind = imufusion::synth::parse_scene_kind(value);
    if (!kind) return bad + " (room, wall or fast)";
    config.scene = *kind;
    opt.have_scene = true;
  } else if (arg == "--out") {
    opt.out = value;
  } else if (arg == "--seed") {
    if (!parse_number(value, config.seed)) return bad;
  } else if (arg == "--frames") {
    if (!parse_number(value, config.frames) || config.frames < 1) return bad;
  } else if (arg == "--size") {
    if (!parse_size(value, config.width, config.height) || config.width < 8 || config.height < 8 ||
        config.width > 8192 || config.height > 8192) {
      return bad + " (WxH, 8..8192)";
    }
    opt.have_size = true;
  } else if (arg == "--fps") {
    if (!parse_number(value, config.fps) || !(config.fps > 0.0) || config.fps > 1000.0) return bad;
    opt.have_fps = true;
  } else if (arg == "--sensor") {
    const auto kind = imufusion::synth::parse_sensor_kind(value);
    if (!kind) return bad + " (kinect or phone-tof)";
    config.sensor = *kind;
  } else {
    return "unknown option " + std::string(arg);
  }
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  SynthConfig& config = opt.config;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (arg == "--no-color") {
      config.color = false;
    } else if (arg == "--no-noise") {
      config.depth_noise = false;
      config.imu_noise = false;
    } else if (arg == "--white-noise") {
      config.white_depth_noise = true;
    } else if (arg == "--overwrite") {
      config.overwrite = true;
    } else if (i + 1 >= argc) {
      return usage_error("missing value after " + std::string(arg));
    } else if (const std::string error = parse_value(arg, argv[++i], opt); !error.empty()) {
      return usage_error(error);
    }
  }
  if (!opt.have_scene) return usage_error("--scene is required");
  if (opt.out.empty()) return usage_error("--out is required");
  const imufusion::synth::SensorFormat format = imufusion::synth::sensor_format(config.sensor);
  if (!opt.have_size) config.width = format.width, config.height = format.height;
  if (!opt.have_fps) config.fps = format.fps;
  const std::string& out = opt.out;

  const auto result = imufusion::synth::synthesize(config, out);
  if (!result.ok()) {
    std::fprintf(stderr, "imufusion-synth: %s\n", result.error().describe().c_str());
    return 1;
  }
  const imufusion::synth::SynthSummary& s = result.value();
  std::printf(
      "wrote %s: scene %s, sensor %s, %d frames, %.3f s, %dx%d, %zu IMU samples at %.0f Hz%s\n",
      out.c_str(), imufusion::synth::to_string(config.scene),
      imufusion::synth::to_string(config.sensor), s.frames, s.duration, s.width, s.height,
      s.imu_samples, config.imu_rate, config.color ? ", colour" : "");
  std::printf("gyro bias (rad/s): %.6f %.6f %.6f\n", s.bias.gyro.x(), s.bias.gyro.y(),
              s.bias.gyro.z());
  if (s.wall_stretch) {
    std::printf("wall stretch: %.3f .. %.3f s%s\n", s.wall_stretch->begin, s.wall_stretch->end,
                s.duration + 1e-9 < s.wall_stretch->end - config.start_time
                    ? " (not fully covered: use more frames)"
                    : "");
  }
  return 0;
}
