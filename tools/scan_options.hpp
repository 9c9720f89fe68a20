#pragma once
// imufusion-scan's command line: its options with their defaults, the usage text, and the
// parser.

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "cli_numbers.hpp"
#include "imufusion/imu_stream.hpp"
#include "imufusion/presets.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/source.hpp"

namespace imufusion::tools {

// imufusion-scan's options, at their defaults.
struct ScanOptions {
  std::filesystem::path input;
  std::filesystem::path out = "scan";
  std::filesystem::path poses;
  std::filesystem::path demo_dir = "demo";
  int demo_frames = 60;
  bool no_imu = false;
  bool no_color = false;
  bool estimate_imu_rotation = false;
  std::optional<int> icp_iterations;
  std::optional<double> photometric_weight;  // IcpPhotometricConfig::weight when given
  std::optional<TranslationModel> translation;
  int recovery_frames = TrackingConfig{}.recovery_frames;
  /// Given: at most recovery_frames (parse_scan_options refuses more); not given: the default,
  /// at most recovery_frames.
  std::optional<int> relocalized_recovery_frames;
  SensorPreset sensor = SensorPreset::kKinect;
  std::optional<float> voxel_size;                  // the preset's when not given
  std::optional<std::array<double, 5>> distortion;  // the lens's, over calibration.txt's
  std::uint32_t block_capacity = VolumeConfig{}.block_capacity;
  std::uint32_t initial_blocks = VolumeConfig{}.initial_blocks;
  int tracking_level = ReconstructorConfig{}.tracking_level;
  int reference_frames = ReconstructorConfig{}.reference_frames;
  long max_frames = -1;  // scanned (kept) frames at most; -1: all
  std::size_t frame_step = 1;
  std::string device;
  bool list_devices = false;
  bool quiet = false;
  DepthMode depth_mode;
  bool realtime = false;
  std::optional<std::uint16_t> imu_udp;
  std::string imu_udp_address = ImuUdpOptions{}.address;
  std::filesystem::path record;
  std::filesystem::path save_state;  // the scan's state, saved after its last frame
  std::filesystem::path resume;      // a saved scan to continue
};

// Writes the usage text to `out`; returns `code`.
inline int scan_usage(std::ostream& out, int code) {
  out << "usage: imufusion-scan [SEQUENCE] [--out DIR] [--sensor kinect|phone-tof] [--no-imu]\n"
         "                      [--icp-iterations N] [--photometric-weight W]\n"
         "                      [--voxel-size M] [--frames N] [--poses FILE] [--device "
         "NAME|INDEX]\n"
         "                      [--list-devices] [--translation "
         "none|constant-velocity|accelerometer]\n"
         "                      [--estimate-imu-rotation] [--recovery-frames N]\n"
         "                      [--relocalized-recovery-frames N] [--no-color]\n"
         "                      [--demo-dir DIR] [--demo-frames N] [--quiet] [--depth-mode "
         "WxH@FPS]\n"
         "                      [--realtime] [--imu-udp PORT] [--imu-udp-address ADDR] [--record "
         "DIR]\n"
         "                      [--frame-step N] [--block-capacity N] [--initial-blocks N]\n"
         "                      [--tracking-level N] [--reference-frames N] [--save-state FILE]\n"
         "                      [--resume FILE] [--distortion K1,K2,P1,P2,K3]\n"
         "Scans SEQUENCE, a camera (openni2:// or openni2://URI) or a recording (FILE.oni) "
         "(default:\n"
         "the embedded demo room, synthesized into --demo-dir, default ./demo) and writes DIR "
         "(default ./scan)/trajectory.txt, frames.csv, mesh.glb, mesh.ply,\n"
         "preview.png, overview.png and summary.json.\n"
         "  --sensor NAME            the sensor's preset: kinect (default; 640x480 structured "
         "light\n"
         "                           or ToF, 0.3-5 m) or phone-tof (240x180 phone ToF, 0.2-4 m)\n"
         "  --no-imu                 track without the gyroscope (the ICP-only baseline)\n"
         "  --icp-iterations N       Gauss-Newton steps per frame, a fixed cap (default "
      << kPresetIcpIterationsWithImu << " with IMU, then on up to "
      << IcpConfig{}.max_unsettled_iterations
      << " while a step\n"
         "                           moves the pose by more than the frame's noise; "
      << kPresetIcpIterationsWithoutImu
      << " without)\n"
         "  --photometric-weight W   the colour's weight in ICP against the depth's, each by\n"
         "                           its own residual (default "
      << IcpPhotometricConfig{}.weight
      << "; 0: depth alone)\n"
         "  --poses FILE             fuse with known camera-to-world poses (TUM format), no "
         "tracking\n"
         "  --frames N               scan at most N frames (counted after --frame-step)\n"
         "  --distortion K1,K2,P1,P2,K3  the depth camera's lens distortion (OpenCV's order;\n"
         "                           default: calibration.txt's, else none); frames are\n"
         "                           resampled to the pinhole on arrival\n"
         "  --frame-step N           scan every Nth frame (0, N, 2N, ...: N times faster motion);\n"
         "                           the IMU samples of skipped frames go with the next kept "
         "frame,\n"
         "                           the outputs cover the kept frames only (default 1)\n"
         "  --estimate-imu-rotation  ignore imu_to_camera.txt and estimate the camera-IMU "
         "rotation\n"
         "  --recovery-frames N      good frames in a row that end a loss (default "
      << TrackingConfig{}.recovery_frames
      << ")\n"
         "  --relocalized-recovery-frames N  the same for a loss the relocalization search "
         "ends,\n"
         "                           at most --recovery-frames (default "
      << TrackingConfig{}.relocalized_recovery_frames
      << ")\n"
         "  --depth-mode WxH@FPS     camera depth mode (default 640x480@30)\n"
         "  --realtime               deliver recorded frames at their recorded pace\n"
         "  --imu-udp PORT           take the IMU from UDP lines (imu.txt or Sensorstream format) "
         "on\n"
         "                           PORT instead of the sequence's imu.txt\n"
         "  --imu-udp-address ADDR   IPv4 address to listen on (default "
      << ImuUdpOptions{}.address
      << ")\n"
         "  --record DIR             write the session's frames and IMU as a sequence into DIR\n"
         "  --block-capacity N       TSDF blocks the volume may grow to (8^3 voxels, 4 KiB each;\n"
         "                           default "
      << VolumeConfig{}.block_capacity
      << ");\n"
         "                           beyond them new surface is not fused (frames.csv pool_full)\n"
         "  --initial-blocks N       TSDF blocks the pool holds at first; it grows as the scene\n"
         "                           needs (default "
      << VolumeConfig{}.initial_blocks
      << ")\n"
         "  --tracking-level N       pyramid level of ICP and the model raycast: 0 full size, 1 "
         "half\n"
         "                           (default: 1 on a CPU device, 0 on a GPU); fusion takes the "
         "full frame\n"
         "  --reference-frames N     frames one model raycast serves as ICP's reference while the\n"
         "                           view moves little (default: "
      << kCpuReferenceFrames
      << " on a CPU device, 1 on a GPU)\n"
         "  --save-state FILE        save the scan after its last frame, to continue it with "
         "--resume\n"
         "  --resume FILE            continue the scan saved in FILE with the sequence's frames "
         "after\n"
         "                           its last one, in its saved configuration (options that set "
         "one\n"
         "                           are ignored); frames.csv and summary.json cover this run's "
         "frames,\n"
         "                           trajectory.txt and the mesh the whole scan\n";
  return code;
}

// A flag without a value: sets it in `opt` and returns true, or false when `a` is none.
inline bool parse_scan_flag(const std::string& a, ScanOptions& opt) {
  bool* flag = a == "--quiet"                   ? &opt.quiet
               : a == "--no-imu"                ? &opt.no_imu
               : a == "--no-color"              ? &opt.no_color
               : a == "--list-devices"          ? &opt.list_devices
               : a == "--estimate-imu-rotation" ? &opt.estimate_imu_rotation
               : a == "--realtime"              ? &opt.realtime
                                                : nullptr;
  if (flag != nullptr) *flag = true;
  return flag != nullptr;
}

// Option `a` with its value `v` into `opt`; returns -1 when taken, else the exit code (2).
inline int parse_scan_value(const std::string& a, const std::string& v, ScanOptions& opt) {
  auto bad = [&](const char* what) {
    return (std::cerr << "error: " << a << " needs " << what << ", got '" << v << "'\n", 2);
  };
  const auto integer = parse_integer(v);
  if (a == "--out")
    opt.out = v;
  else if (a == "--poses")
    opt.poses = v;
  else if (a == "--device")
    opt.device = v;
  else if (a == "--demo-dir")
    opt.demo_dir = v;
  else if (a == "--record")
    opt.record = v;
  else if (a == "--save-state")
    opt.save_state = v;
  else if (a == "--resume")
    opt.resume = v;
  else if (a == "--imu-udp-address")
    opt.imu_udp_address = v;
  else if (a == "--sensor") {
    const auto sensor = parse_sensor_preset(v);
    if (!sensor) return bad("kinect or phone-tof");
    opt.sensor = *sensor;
  } else if (a == "--depth-mode") {
    auto mode = parse_depth_mode(v);
    if (!mode) return (std::cerr << "error: " << mode.error().describe() << "\n", 2);
    opt.depth_mode = *mode;
  } else if (a == "--imu-udp") {
    if (!integer || *integer < 1 || *integer > 65535) return bad("a UDP port 1..65535");
    opt.imu_udp = static_cast<std::uint16_t>(*integer);
  } else if (a == "--icp-iterations") {
    if (!integer || *integer < 1 || *integer > 100) return bad("a count 1..100");
    opt.icp_iterations = static_cast<int>(*integer);
  } else if (a == "--frames") {
    if (!integer || *integer < 1) return bad("a positive count");
    opt.max_frames = static_cast<long>(*integer);
  } else if (a == "--frame-step") {
    if (!integer || *integer < 1) return bad("an integer >= 1");
    opt.frame_step = static_cast<std::size_t>(*integer);
  } else if (a == "--demo-frames") {
    if (!integer || *integer < 2 || *integer > 100000) return bad("a count of at least 2");
    opt.demo_frames = static_cast<int>(*integer);
  } else if (a == "--recovery-frames") {
    if (!integer || *integer < 1 || *integer > 1000) return bad("a positive count");
    opt.recovery_frames = static_cast<int>(*integer);
  } else if (a == "--relocalized-recovery-frames") {
    if (!integer || *integer < 1 || *integer > 1000) return bad("a positive count");
    opt.relocalized_recovery_frames = static_cast<int>(*integer);
  } else if (a == "--tracking-level") {
    if (!integer || *integer < 0 || *integer > 2) return bad("a pyramid level 0..2");
    opt.tracking_level = static_cast<int>(*integer);
  } else if (a == "--reference-frames") {
    if (!integer || *integer < 1 || *integer > 1000) return bad("a count 1..1000");
    opt.reference_frames = static_cast<int>(*integer);
  } else if (a == "--block-capacity") {
    if (!integer || *integer < 1 || *integer > (1 << 21)) return bad("a count 1..2097152");
    opt.block_capacity = static_cast<std::uint32_t>(*integer);
  } else if (a == "--initial-blocks") {
    if (!integer || *integer < 1 || *integer > (1 << 21)) return bad("a count 1..2097152");
    opt.initial_blocks = static_cast<std::uint32_t>(*integer);
  } else if (a == "--distortion") {
    std::vector<std::string> fields(1);
    for (char c : v) {
      if (c == ',')
        fields.emplace_back();
      else
        fields.back().push_back(c);
    }
    std::array<double, 5> d{};
    if (fields.size() != d.size()) return bad("five numbers K1,K2,P1,P2,K3");
    for (std::size_t i = 0; i < d.size(); ++i) {
      const auto c = parse_number(fields[i]);
      if (!c) return bad("five numbers K1,K2,P1,P2,K3");
      d[i] = *c;
    }
    opt.distortion = d;
  } else if (a == "--voxel-size") {
    const auto m = parse_number(v);
    if (!m || *m < 0.001 || *m > 0.5) return bad("metres in [0.001, 0.5]");
    opt.voxel_size = static_cast<float>(*m);
  } else if (a == "--photometric-weight") {
    const auto w = parse_number(v);
    if (!w || *w < 0 || *w > 100) return bad("a weight in [0, 100]");
    opt.photometric_weight = *w;
  } else if (a == "--translation") {
    opt.translation = parse_translation_model(v);
    if (!opt.translation) return bad("none, constant-velocity or accelerometer");
  } else {
    std::cerr << "error: unknown option " << a << "\n";
    return scan_usage(std::cerr, 2);
  }
  return -1;
}

// Parses the command line into `opt`; returns -1 to scan, else the exit code (0 for --help).
inline int parse_scan_options(int argc, char** argv, ScanOptions& opt) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") return scan_usage(std::cout, 0);
    if (parse_scan_flag(a, opt)) continue;
    if (a.size() > 1 && a[0] == '-') {
      if (i + 1 >= argc)
        return (std::cerr << "error: " << a << " needs a value\n", scan_usage(std::cerr, 2));
      if (const int rc = parse_scan_value(a, argv[++i], opt); rc >= 0) return rc;
    } else if (opt.input.empty()) {
      opt.input = a;
    } else {
      std::cerr << "error: more than one input: " << opt.input << " and " << a << "\n";
      return scan_usage(std::cerr, 2);
    }
  }
  if (opt.relocalized_recovery_frames && *opt.relocalized_recovery_frames > opt.recovery_frames) {
    std::cerr << "error: --relocalized-recovery-frames " << *opt.relocalized_recovery_frames
              << " is above --recovery-frames " << opt.recovery_frames
              << " (a relocalized frame needs at most the frames any recovery needs)\n";
    return scan_usage(std::cerr, 2);
  }
  return -1;
}

}  // namespace imufusion::tools
