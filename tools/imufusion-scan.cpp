// imufusion-scan [INPUT] [options]
//
// Scans a sequence, an OpenNI2 camera (openni2://[URI]) or recording (FILE.oni): IMU-seeded
// frame-to-model ICP, dead reckoning while tracking is unreliable, fusion into the sparse TSDF
// volume (Reconstructor). Without INPUT it scans the embedded demo (the synthetic furnished room,
// synthesized on the first run). Writes into --out DIR: trajectory.txt, frames.csv, mesh.glb,
// mesh.ply, preview.png, overview.png and summary.json, as one set that replaces an earlier run's
// (io/output_set.hpp; --out is checked before the scan); a failure, Ctrl-C or SIGTERM mid-scan
// still writes the outputs of the frames done. IMU samples no sensor gives are left out
// (io/imu_gate.hpp); an imu.txt that covers none of the frames is not used.
// --imu-udp takes the IMU from a UDP stream instead of the sequence (scan_live.hpp); --record
// writes the session (frames and IMU) as a sequence; --frame-step N scans every Nth frame with
// all of the IMU (frame_step.hpp).

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cli_numbers.hpp"
#include "demo_sequence.hpp"
#include "frame_step.hpp"
#include "imufusion/eval.hpp"
#include "imufusion/image_io.hpp"
#include "imufusion/presets.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/scan_report.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/source.hpp"
#include "imufusion/trajectory.hpp"
#include "io/atomic_file.hpp"
#include "io/line_appender.hpp"
#include "io/output_set.hpp"
#include "io/sequence_check.hpp"
#include "json_text.hpp"
#include "overview_pose.hpp"
#include "scan_live.hpp"

namespace fs = std::filesystem;
using namespace imufusion;

namespace {

// The signal that asked the scan to stop (SIGINT or SIGTERM), 0 while none did: the scan ends
// after its current frame and writes every output, as at the end of the input.
volatile std::sig_atomic_t g_interrupted = 0;
void on_interrupt(int signal) { g_interrupted = signal; }

struct Options {
  fs::path input;
  fs::path out = "scan";
  fs::path poses;
  fs::path demo_dir = "demo";
  int demo_frames = 60;
  bool no_imu = false;
  bool no_color = false;
  bool estimate_imu_rotation = false;
  std::optional<int> icp_iterations;
  std::optional<TranslationModel> translation;
  int recovery_frames = TrackingConfig{}.recovery_frames;
  float voxel_size = 0.01f;
  std::uint32_t block_capacity = VolumeConfig{}.block_capacity;
  int tracking_level = ReconstructorConfig{}.tracking_level;
  long max_frames = -1;  // scanned (kept) frames at most; -1: all
  std::size_t frame_step = 1;
  std::string device;
  bool list_devices = false;
  bool quiet = false;
  DepthMode depth_mode;
  bool realtime = false;
  std::optional<std::uint16_t> imu_udp;
  std::string imu_udp_address = ImuUdpOptions{}.address;
  fs::path record;
};

int usage(std::ostream& out, int code) {
  out << "usage: imufusion-scan [SEQUENCE] [--out DIR] [--no-imu] [--icp-iterations N]\n"
         "                      [--voxel-size M] [--frames N] [--poses FILE] [--device "
         "NAME|INDEX]\n"
         "                      [--list-devices] [--translation "
         "none|constant-velocity|accelerometer]\n"
         "                      [--estimate-imu-rotation] [--recovery-frames N] [--no-color]\n"
         "                      [--demo-dir DIR] [--demo-frames N] [--quiet] [--depth-mode "
         "WxH@FPS]\n"
         "                      [--realtime] [--imu-udp PORT] [--imu-udp-address ADDR] [--record "
         "DIR]\n"
         "                      [--frame-step N] [--block-capacity N] [--tracking-level N]\n"
         "Scans SEQUENCE, a camera (openni2:// or openni2://URI) or a recording (FILE.oni) "
         "(default:\n"
         "the embedded demo room, synthesized into --demo-dir, default ./demo) and writes DIR "
         "(default ./scan)/trajectory.txt, frames.csv, mesh.glb, mesh.ply,\n"
         "preview.png, overview.png and summary.json.\n"
         "  --no-imu                 track without the gyroscope (the ICP-only baseline)\n"
         "  --icp-iterations N       Gauss-Newton steps per frame at most (default "
      << kPresetIcpIterationsWithImu << " with IMU, " << kPresetIcpIterationsWithoutImu
      << " without)\n"
         "  --poses FILE             fuse with known camera-to-world poses (TUM format), no "
         "tracking\n"
         "  --frames N               scan at most N frames (counted after --frame-step)\n"
         "  --frame-step N           scan every Nth frame (0, N, 2N, ...: N times faster motion);\n"
         "                           the IMU samples of skipped frames go with the next kept "
         "frame,\n"
         "                           the outputs cover the kept frames only (default 1)\n"
         "  --estimate-imu-rotation  ignore imu_to_camera.txt and estimate the camera-IMU "
         "rotation\n"
         "  --depth-mode WxH@FPS     camera depth mode (default 640x480@30)\n"
         "  --realtime               deliver recorded frames at their recorded pace\n"
         "  --imu-udp PORT           take the IMU from UDP lines (imu.txt or Sensorstream format) "
         "on\n"
         "                           PORT instead of the sequence's imu.txt\n"
         "  --imu-udp-address ADDR   IPv4 address to listen on (default "
      << ImuUdpOptions{}.address
      << ")\n"
         "  --record DIR             write the session's frames and IMU as a sequence into DIR\n"
         "  --block-capacity N       TSDF blocks the volume holds (8^3 voxels, 4 KiB each; default "
      << VolumeConfig{}.block_capacity
      << ");\n"
         "                           beyond them new surface is not fused (frames.csv pool_full)\n"
         "  --tracking-level N       pyramid level of ICP and the model raycast: 0 full size, 1 "
         "half\n"
         "                           (default: 1 on a CPU device, 0 on a GPU); fusion takes the "
         "full frame\n";
  return code;
}

int parse(int argc, char** argv, Options& opt) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") return usage(std::cout, 0);
    if (a == "--quiet") {
      opt.quiet = true;
      continue;
    }
    if (a == "--no-imu") {
      opt.no_imu = true;
      continue;
    }
    if (a == "--no-color") {
      opt.no_color = true;
      continue;
    }
    if (a == "--list-devices") {
      opt.list_devices = true;
      continue;
    }
    if (a == "--estimate-imu-rotation") {
      opt.estimate_imu_rotation = true;
      continue;
    }
    if (a == "--realtime") {
      opt.realtime = true;
      continue;
    }
    if (a.size() > 1 && a[0] == '-') {
      if (i + 1 >= argc)
        return (std::cerr << "error: " << a << " needs a value\n", usage(std::cerr, 2));
      const std::string v = argv[++i];
      auto bad = [&](const char* what) {
        return (std::cerr << "error: " << a << " needs " << what << ", got '" << v << "'\n", 2);
      };
      const auto integer = tools::parse_integer(v);
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
      else if (a == "--imu-udp-address")
        opt.imu_udp_address = v;
      else if (a == "--depth-mode") {
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
      } else if (a == "--tracking-level") {
        if (!integer || *integer < 0 || *integer > 2) return bad("a pyramid level 0..2");
        opt.tracking_level = static_cast<int>(*integer);
      } else if (a == "--block-capacity") {
        if (!integer || *integer < 1 || *integer > (1 << 21)) return bad("a count 1..2097152");
        opt.block_capacity = static_cast<std::uint32_t>(*integer);
      } else if (a == "--voxel-size") {
        const auto m = tools::parse_number(v);
        if (!m || *m < 0.001 || *m > 0.5) return bad("metres in [0.001, 0.5]");
        opt.voxel_size = static_cast<float>(*m);
      } else if (a == "--translation") {
        opt.translation = parse_translation_model(v);
        if (!opt.translation) return bad("none, constant-velocity or accelerometer");
      } else {
        std::cerr << "error: unknown option " << a << "\n";
        return usage(std::cerr, 2);
      }
    } else if (opt.input.empty()) {
      opt.input = a;
    } else {
      std::cerr << "error: more than one input: " << opt.input << " and " << a << "\n";
      return usage(std::cerr, 2);
    }
  }
  return -1;
}

int fail(const std::string& message) {
  std::cerr << "error: " << message << "\n";
  return 1;
}

int print_devices() {
  auto devices = list_devices();
  if (!devices) return fail(devices.error().describe());
  for (const DeviceInfo& d : *devices)
    std::printf("%d: %s (%s, %s)\n", d.index, d.name.c_str(), to_string(d.type), d.driver.c_str());
  return 0;
}

// The status line: a progress bar when the frame count is known (0: a camera), the tracking
// state and the ICP quality of the latest frame.
void show_progress(std::size_t done, std::size_t total, const FrameResult& f, double fps) {
  constexpr int kWidth = 30;
  std::string count = std::to_string(done) + " frames";
  if (total > 0) {
    const auto filled = static_cast<std::size_t>(kWidth * done / total);
    count = "[" + std::string(filled, '#') + std::string(kWidth - filled, ' ') + "] " +
            std::to_string(done) + "/" + std::to_string(total);
  }
  std::fprintf(stderr, "\r%s  %.1f fps  %-14s icp %d it %llu inliers kappa %.0f  ", count.c_str(),
               fps, tools::tracking_state(f), f.icp_ran ? f.icp.quality.iterations : 0,
               static_cast<unsigned long long>(f.icp_ran ? f.icp.quality.inliers : 0),
               f.icp_ran ? f.icp.quality.condition : 0.0);
  std::fflush(stderr);
}

// Why the sequence's imu.txt cannot aid the scan (it covers none of the frames, e.g. on another
// clock), or empty when it can or is not used.
std::string sequence_imu_unusable(const Options& opt, const SequenceReader* reader) {
  if (opt.no_imu || opt.imu_udp || reader == nullptr || !reader->has_imu()) return {};
  const std::vector<double> stamps = reader->timestamps();
  if (io::frames_within_imu(reader->imu(), stamps) > 0) return {};
  const auto& imu = reader->imu();
  char span[160];
  if (imu.empty()) {
    std::snprintf(span, sizeof span, "has no usable sample");
  } else {
    std::snprintf(
        span, sizeof span, "(%.3f .. %.3f s) covers none of the %zu frames (%.3f .. %.3f s)",
        imu.front().timestamp, imu.back().timestamp, stamps.size(), stamps.front(), stamps.back());
  }
  return (reader->info().directory / "imu.txt").string() + " " + span +
         ": scanning without the IMU (the --no-imu settings)";
}

// `reader`: the sequence when the input is one (null for a camera or .oni recording);
// `sequence_imu`: whether its imu.txt can aid the scan.
ReconstructorConfig make_config(const Options& opt, const SequenceReader* reader,
                                const FrameSource* source, const Intrinsics& k, bool sequence_imu) {
  const bool with_imu =
      !opt.no_imu && (opt.imu_udp || (reader != nullptr && reader->has_imu() && sequence_imu));
  ReconstructorConfig config = preset_config(SensorPreset::kKinect, k, with_imu);
  config.volume.voxel_size = opt.voxel_size;
  config.volume.block_capacity = opt.block_capacity;
  config.tracking_level = opt.tracking_level;
  // The hash table keeps at least 4 slots per block, as the defaults do.
  while (config.volume.hash_slots < 4ull * opt.block_capacity) config.volume.hash_slots *= 2;
  config.device.selector = opt.device;
  if (opt.icp_iterations) config.icp.max_total_iterations = *opt.icp_iterations;
  config.tracking.recovery_frames = opt.recovery_frames;
  std::optional<Eigen::Isometry3d> T_camera_imu =
      source != nullptr ? source->T_camera_imu() : std::nullopt;
  if (reader != nullptr && reader->info().has_imu_to_camera)
    T_camera_imu = reader->info().T_camera_imu;
  config.inertial.T_camera_imu_known = T_camera_imu.has_value() && !opt.estimate_imu_rotation;
  config.inertial.T_camera_imu =
      config.inertial.T_camera_imu_known ? *T_camera_imu : Eigen::Isometry3d::Identity();
  if (reader != nullptr) {
    const auto& info = reader->info().info;
    if (auto noise = info.find("gyro_noise_density"); noise != info.end()) {
      if (auto v = tools::parse_number(noise->second); v && *v > 0)
        config.inertial.gyro_noise_density = *v;
    }
  }
  if (opt.translation) config.inertial.translation = *opt.translation;
  return config;
}

// What the scan keeps of its frames: frames.csv's rows go to disk as the frames come, the
// statistics are summed as they go, so a long scan grows by its trajectory alone.
struct ScanRun {
  std::filesystem::path frames_csv;  // in the output set's staging directory
  io::LineAppender frames_csv_rows;
  Status frames_csv_status;  // the first failure to write a row
  ScanSummary summary;
  std::optional<FrameResult> last;  // the latest scanned frame
  std::string stopped;              // why the scan ended early, empty when it ran through
  std::string imu_fallback;         // why the sequence's IMU was not used, empty when it was
  bool pool_full_reported = false;
  std::size_t frames_without_pose = 0;
};

// summary.json's "stage_ms" (mean wall ms per frame of each stage) and "kernel_gpu_ms" (mean GPU
// ms per frame of each kernel, slowest first, with its dispatches per frame).
void write_stage_times(const ScanStatistics& stats, nlohmann::json& j) {
  const FrameTimings& t = stats.mean_stage_ms;
  j["stage_ms"] = {{"preprocess", t.preprocess_ms},
                   {"icp", t.icp_ms},
                   {"integrate", t.integrate_ms},
                   {"raycast", t.raycast_ms},
                   {"relocalize", t.relocalize_ms},
                   {"retrack", t.retrack_ms},
                   {"total", t.total_ms}};
  nlohmann::json kernels = nlohmann::json::array();
  for (const auto& k : stats.mean_kernels)
    kernels.push_back({{"kernel", k.kernel}, {"gpu_ms", k.gpu_ms}, {"dispatches", k.dispatches}});
  j["kernel_gpu_ms"] = kernels;
}

nlohmann::json summary_json(const Options& opt, const Reconstructor& rec, const ScanRun& run,
                            const ScanStatistics& stats, const SequenceReader* reader,
                            const std::string& input) {
  const ReconstructorConfig& c = rec.config();
  nlohmann::json j;
  j["input"] = input;
  j["device"] = rec.device().name;
  j["frames"] = stats.frames;
  j["frames_fused"] = stats.fused;
  j["lost_frames"] = stats.lost;
  j["recovering_frames"] = stats.recovering;
  j["dead_reckoned_frames"] = stats.dead_reckoned;
  j["partial_icp_frames"] = stats.partial;
  j["recoveries"] = stats.recoveries;
  j["broken_recoveries"] = stats.broken_recoveries;
  j["relocalizations"] = stats.relocalizations;
  j["recovery_restarts"] = stats.recovery_restarts;
  j["retracked_frames"] = stats.retracked;
  j["frames_to_recover"] = stats.recovery_frames;
  j["mean_icp_iterations"] = stats.mean_icp_iterations;
  j["median_icp_iterations"] = stats.median_icp_iterations;
  j["median_icp_iterations_tracking"] = stats.median_icp_iterations_tracking;
  j["fps"] = stats.fps;
  j["median_frame_ms"] = stats.median_frame_ms;
  write_stage_times(stats, j);
  j["blocks_allocated"] = rec.allocated_blocks();
  j["block_capacity"] = rec.config().volume.block_capacity;
  j["pool_full_frames"] = stats.pool_full_frames;
  if (stats.pool_full_frames > 0) j["first_pool_full_frame"] = stats.first_pool_full_frame;
  j["volume_bytes_reserved"] = rec.memory_bytes();
  if (!run.stopped.empty()) j["stopped_early"] = run.stopped;
  if (run.frames_without_pose > 0) j["frames_without_pose"] = run.frames_without_pose;
  auto& s = j["settings"];
  s["mode"] = opt.poses.empty() ? "track" : "known_poses";
  s["frame_step"] = opt.frame_step;
  s["imu"] = c.imu.enabled;
  s["imu_in_sequence"] = reader != nullptr && reader->has_imu();
  if (!run.imu_fallback.empty()) s["imu_fallback"] = run.imu_fallback;
  if (reader != nullptr && reader->has_imu()) {
    j["imu_rejected"] = {{"implausible", reader->info().imu_implausible},
                         {"time_jumps", reader->info().imu_time_jumps}};
  }
  s["imu_source"] = !c.imu.enabled ? "none" : opt.imu_udp ? "udp" : "sequence";
  s["icp_iterations_cap"] = c.icp.max_total_iterations;
  const Intrinsics tracked = c.intrinsics.at_level(rec.tracking_level());
  s["tracking_level"] = rec.tracking_level();
  s["tracking_size"] = std::to_string(tracked.width) + "x" + std::to_string(tracked.height);
  s["recovery_icp_iterations"] = c.recovery.icp_iterations;
  s["recovery_frames"] = c.tracking.recovery_frames;
  s["translation_model"] = to_string(c.inertial.translation);
  s["camera_imu_rotation"] = c.inertial.T_camera_imu_known ? "given" : "estimated";
  s["voxel_size"] = c.volume.voxel_size;
  s["truncation"] = c.volume.truncation();
  s["width"] = c.intrinsics.width;
  s["height"] = c.intrinsics.height;
  if (run.last && c.imu.enabled) {
    const InertialStatus& in = run.last->inertial;
    auto& imu = j["imu_estimates"];
    imu["gyro_bias"] = {in.gyro_bias.x(), in.gyro_bias.y(), in.gyro_bias.z()};
    imu["gyro_bias_sigma"] = {in.gyro_bias_sigma.x(), in.gyro_bias_sigma.y(),
                              in.gyro_bias_sigma.z()};
    imu["gyro_bias_updates"] = in.bias_updates;
    imu["gyro_bias_rejected"] = in.bias_rejected;
    if (in.gravity_ready) {
      imu["gravity_world"] = {in.gravity_world.x(), in.gravity_world.y(), in.gravity_world.z()};
      imu["gravity_sigma"] = {in.gravity_sigma.x(), in.gravity_sigma.y(), in.gravity_sigma.z()};
      imu["accel_bias"] = {in.accel_bias.x(), in.accel_bias.y(), in.accel_bias.z()};
      imu["accel_bias_sigma"] = {in.accel_bias_sigma.x(), in.accel_bias_sigma.y(),
                                 in.accel_bias_sigma.z()};
    }
    imu["R_camera_imu_xyzw"] = {in.R_camera_imu.x(), in.R_camera_imu.y(), in.R_camera_imu.z(),
                                in.R_camera_imu.w()};
    imu["R_camera_imu_estimated"] = in.R_camera_imu_estimated;
    imu["R_camera_imu_sigma_deg"] = in.R_camera_imu_sigma_deg;
    imu["hand_eye_pairs"] = in.hand_eye_pairs;
  }
  if (reader != nullptr && reader->has_ground_truth() && stats.frames >= 3) {
    auto ate = evaluate_ate(reader->ground_truth(), rec.trajectory());
    if (ate) {
      j["ate"] = {{"rmse", ate->stats.rmse},
                  {"mean", ate->stats.mean},
                  {"median", ate->stats.median},
                  {"max", ate->stats.max},
                  {"matched", ate->stats.count}};
    } else {
      j["ate_error"] = ate.error().message;
    }
  }
  return j;
}

// The outputs of a scan, replaced as one set; summary.json, last, marks the set complete.
const std::vector<std::string> kOutputs = {"trajectory.txt", "frames.csv",  "mesh.glb",
                                           "mesh.ply",       "preview.png", "overview.png",
                                           "summary.json"};

// Writes every output of the frames scanned so far into the set's staging directory; returns
// the first failure.
Status write_outputs(const io::OutputSet& set, Reconstructor& rec, ScanRun& run,
                     const nlohmann::json& summary_in, std::string* mesh_line) {
  IMUFUSION_RETURN_IF_ERROR(
      write_trajectory(set.staged("trajectory.txt"), rec.trajectory(),
                       "camera-to-world poses of imufusion-scan, one per scanned frame"));
  IMUFUSION_RETURN_IF_ERROR(run.frames_csv_status);
  run.frames_csv_rows.close();
  nlohmann::json summary = summary_in;
  auto mesh = rec.extract_mesh();
  if (!mesh) return mesh.error();
  summary["mesh_vertices"] = mesh->vertices.size();
  summary["mesh_triangles"] = mesh->triangles.size();
  if (!mesh->triangles.empty()) {
    IMUFUSION_RETURN_IF_ERROR(write_glb(set.staged("mesh.glb"), *mesh));
    IMUFUSION_RETURN_IF_ERROR(write_ply(set.staged("mesh.ply"), *mesh));
    auto preview = rec.raycast(rec.trajectory().back().T_world_camera);
    if (!preview) return preview.error();
    IMUFUSION_RETURN_IF_ERROR(write_color_png(set.staged("preview.png"), preview->shaded));
    auto volume = rec.snapshot();
    if (!volume) return volume.error();
    auto overview =
        rec.raycast(tools::overview_pose(*volume, rec.trajectory().front().T_world_camera,
                                         rec.config().intrinsics),
                    std::nullopt, std::pair{0.1f, 100.0f});
    if (!overview) return overview.error();
    IMUFUSION_RETURN_IF_ERROR(write_color_png(set.staged("overview.png"), overview->shaded));
    *mesh_line = "mesh " + std::to_string(mesh->triangles.size()) + " triangles -> " +
                 set.final_path("mesh.glb").string() + ", preview -> " +
                 set.final_path("preview.png").string();
  } else {
    *mesh_line = "no surface was fused: no mesh or preview written";
  }
  return io::write_text_atomically(set.staged("summary.json"), tools::json_text(summary) + "\n");
}

bool is_device_input(const fs::path& input) {
  return input.string().rfind("openni2://", 0) == 0 || input.extension() == ".oni";
}

// A recorder for --record: calibration, imu_to_camera and the sequence's info lines.
Result<SessionRecorder> open_recorder(const Options& opt, const ReconstructorConfig& c,
                                      const SequenceReader* reader) {
  auto recorder = SessionRecorder::create(opt.record);
  if (!recorder) return recorder.error();
  recorder->set_intrinsics(c.intrinsics);
  if (c.inertial.T_camera_imu_known) recorder->set_T_camera_imu(c.inertial.T_camera_imu);
  if (reader != nullptr) {
    for (const auto& [key, value] : reader->info().info) recorder->set_info(key, value);
  }
  return recorder;
}

// A sequence is read by SequenceReader (ground truth, info, frame count); cameras, .oni
// recordings and paced sequences (--realtime) deliver their frames through a FrameSource.
struct ScanInput {
  std::optional<SequenceReader> reader;
  std::unique_ptr<FrameSource> source;
};

// Opens `input` into `in`; returns the error message, empty on success.
std::string open_input(const Options& opt, const fs::path& input, ScanInput& in) {
  if (!is_device_input(input)) {
    SequenceOptions sequence_options;
    sequence_options.load_color = !opt.no_color;
    auto opened = SequenceReader::open(input, sequence_options);
    if (!opened) return opened.error().describe();
    if (!opened->intrinsics()) return (input / "calibration.txt").string() + " is missing";
    if (opened->frame_count() == 0) return (input / "depth.txt").string() + " lists no frames";
    in.reader = std::move(*opened);
  }
  if (!in.reader || opt.realtime) {
    SourceOptions source_options;
    source_options.depth_mode = opt.depth_mode;
    source_options.color = !opt.no_color;
    source_options.realtime = opt.realtime;
    source_options.sequence.load_color = !opt.no_color;
    auto opened = open_frame_source(input.string(), source_options);
    if (!opened) return opened.error().describe();
    in.source = std::move(*opened);
  }
  return {};
}

// --frames: the most frames scanned (after --frame-step).
std::size_t frame_limit(const Options& opt) {
  return opt.max_frames > 0 ? static_cast<std::size_t>(opt.max_frames) : SIZE_MAX;
}

// One frame tracked and fused, or fused at its pose from --poses (nullopt: --poses has none).
Result<std::optional<FrameResult>> scan_one(const Options& opt, Reconstructor& rec,
                                            const Trajectory& known, const Frame& frame) {
  const ColorImage* color = frame.color ? &*frame.color : nullptr;
  Result<FrameResult> result = make_error(ErrorCode::kInternal, "no frame");
  if (!opt.poses.empty()) {
    const StampedPose* pose = find_pose(known, frame.timestamp);
    if (pose == nullptr) return std::optional<FrameResult>{};
    result =
        rec.fuse_with_pose(frame.timestamp, frame.depth, color, pose->T_world_camera, frame.imu);
  } else {
    result = rec.track_and_fuse(frame.timestamp, frame.depth, color, frame.imu);
  }
  if (!result) return result.error();
  return std::optional<FrameResult>(std::move(*result));
}

// What the scan loop reads: the kept frames (`total` of them expected, 0 when unknown), the UDP
// IMU stream and the recorder (each optional), and the poses of --poses.
struct ScanInputs {
  tools::SteppedFrames& frames;
  std::size_t total;
  std::optional<tools::LiveImu>& imu;
  std::optional<SessionRecorder>& recorder;
  const Trajectory& known;
};

// Scans until the input ends, --frames frames are done, a frame fails or SIGINT/SIGTERM, then
// settles a scan that ends while recovering (Reconstructor::finish). Returns the exit code.
int scan_frames(const Options& opt, Reconstructor& rec, ScanInputs in, ScanRun& run) {
  const std::size_t limit = frame_limit(opt);
  const bool progress = !opt.quiet && isatty(STDERR_FILENO);
  int exit_code = 0;
  double elapsed_ms = 0;
  for (std::size_t i = 0; i < limit; ++i) {
    if (g_interrupted) {
      run.stopped = std::string(g_interrupted == SIGTERM ? "terminated (SIGTERM)" : "interrupted") +
                    " after " + std::to_string(i) + " frames";
      exit_code = 128 + g_interrupted;
      break;
    }
    auto next = in.frames.next();
    if (!next) {
      run.stopped = next.error().describe();
      exit_code = 1;
      break;
    }
    if (!*next) break;  // the end of the recording
    Frame& frame = **next;
    // The recorder takes IMU samples on the IMU's clock: the sequence's are on the frame clock
    // already, the stream's are mapped for tracking and shifted by the final offset at finish().
    std::vector<ImuSample> imu_raw = frame.imu;
    if (in.imu) frame.imu = in.imu->take(frame.timestamp, &imu_raw);
    if (in.recorder) {
      if (in.imu) in.recorder->set_imu_clock_offset(in.imu->imu_to_frame_offset());
      in.recorder->push_imu(imu_raw);
      in.recorder->push_frame(frame);
    }
    auto result = scan_one(opt, rec, in.known, frame);
    if (!result) {
      run.stopped = "frame " + std::to_string(i) + " (t=" + std::to_string(frame.timestamp) +
                    "): " + result.error().describe();
      exit_code = 1;
      break;
    }
    if (!*result) {
      ++run.frames_without_pose;
      continue;
    }
    elapsed_ms += (*result)->timings.total_ms;
    if (in.imu) in.imu->observe(**result);
    if ((*result)->fused && (*result)->integration.pool_full > 0 && !run.pool_full_reported) {
      run.pool_full_reported = true;
      std::cerr << (progress ? "\n" : "") << "warning: the volume's block pool ("
                << rec.config().volume.block_capacity << " blocks) is full from frame " << i
                << ": surface in new blocks is no longer fused (frames.csv "
                   "pool_full); scan with a larger --voxel-size (now "
                << rec.config().volume.voxel_size << " m) or --block-capacity\n";
    }
    if (run.frames_csv_status.ok()) {
      run.frames_csv_status =
          run.frames_csv_rows.append(run.frames_csv, frames_csv_header() + "\n",
                                     frames_csv_row(**result, rec.allocated_blocks()) + "\n");
    }
    run.summary.add(**result);
    run.last = std::move(**result);
    const double frames_done = static_cast<double>(run.summary.frames());
    if (progress) show_progress(i + 1, in.total, *run.last, 1000.0 * frames_done / elapsed_ms);
  }
  if (progress) std::fputc('\n', stderr);
  if (run.last) {
    auto placed = rec.finish();
    if (placed) {
      run.summary.add_retracked(*placed);
    } else if (run.stopped.empty()) {
      run.stopped = "ending the scan: " + placed.error().describe();
      exit_code = 1;
    }
  }
  return exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (const int rc = parse(argc, argv, opt); rc >= 0) return rc;
  if (opt.list_devices) return print_devices();

  fs::path input = opt.input;
  if (input.empty()) {
    auto demo = tools::ensure_demo_sequence(opt.demo_dir, opt.demo_frames);
    if (!demo) return fail(demo.error().describe());
    input = *demo;
  }
  ScanInput in;
  if (const std::string error = open_input(opt, input, in); !error.empty()) return fail(error);
  std::optional<SequenceReader>& reader = in.reader;
  std::unique_ptr<FrameSource>& source = in.source;
  Trajectory known;
  if (!opt.poses.empty()) {
    auto read = read_trajectory(opt.poses);
    if (!read) return fail(read.error().describe());
    known = std::move(*read);
  }
  Intrinsics k = reader ? *reader->intrinsics() : source->intrinsics();
  if (reader) {
    k.width = reader->info().width;
    k.height = reader->info().height;
  }
  // --out is checked before the scan: a live scan must not find it unwritable at the end.
  auto outputs = io::OutputSet::begin(opt.out, kOutputs);
  if (!outputs) return fail(outputs.error().describe());
  const SequenceReader* sequence = reader ? &*reader : nullptr;
  ScanRun run;
  run.frames_csv = outputs->staged("frames.csv");
  run.imu_fallback = sequence_imu_unusable(opt, sequence);
  if (!run.imu_fallback.empty()) std::cerr << "warning: " << run.imu_fallback << "\n";
  if (sequence != nullptr &&
      (sequence->info().imu_implausible > 0 || sequence->info().imu_time_jumps > 0)) {
    std::cerr << "warning: " << (sequence->info().directory / "imu.txt").string() << ": left out "
              << sequence->info().imu_implausible << " samples beyond a real IMU's range and "
              << sequence->info().imu_time_jumps << " jumps in time\n";
  }
  auto rec =
      Reconstructor::create(make_config(opt, sequence, source.get(), k, run.imu_fallback.empty()));
  if (!rec) return fail(rec.error().describe());
  std::optional<tools::LiveImu> imu;
  if (opt.imu_udp) {
    auto opened = tools::LiveImu::open(*opt.imu_udp, opt.imu_udp_address);
    if (!opened) return fail(opened.error().describe());
    imu.emplace(std::move(*opened));
  }
  std::optional<SessionRecorder> recorder;
  if (!opt.record.empty()) {
    auto opened = open_recorder(opt, rec->config(), sequence);
    if (!opened) return fail(opened.error().describe());
    recorder.emplace(std::move(*opened));
  }
  if (imu && !opt.quiet) std::cerr << "imu: listening on " << imu->endpoint() << std::endl;

  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  const std::size_t limit = frame_limit(opt);
  tools::SteppedFrames frames(source ? nullptr : &*reader, source.get(), opt.frame_step);
  const std::size_t total = reader ? std::min(frames.kept_of(reader->frame_count()), limit)
                                   : (opt.max_frames > 0 ? limit : 0);
  int exit_code = scan_frames(opt, *rec, ScanInputs{frames, total, imu, recorder, known}, run);
  if (!run.stopped.empty())
    std::cerr << (exit_code > 128 ? "stopped: " : "error: ") << run.stopped << "\n";
  nlohmann::json recording;
  if (recorder) {
    if (imu) recorder->set_imu_clock_offset(imu->imu_to_frame_offset());
    const Status finished = recorder->finish();
    if (!finished) {
      std::cerr << "error: recording into " << opt.record.string() << ": "
                << finished.error().describe() << "\n";
      if (exit_code == 0) exit_code = 1;
    }
    recording = tools::recorder_report(*recorder, finished);
  }
  if (!run.last) return fail("no frame was scanned; nothing written");

  const ScanStatistics stats = run.summary.statistics();
  nlohmann::json summary = summary_json(opt, *rec, run, stats, sequence, input.string());
  if (imu) summary["imu_stream"] = imu->report();
  if (recorder) summary["recording"] = recording;
  std::string mesh_line;
  if (auto s = write_outputs(*outputs, *rec, run, summary, &mesh_line); !s) {
    return fail(s.error().describe() + " (the outputs of an earlier run in " + opt.out.string() +
                " are as they were)");
  }
  if (auto s = outputs->commit(); !s) return fail(s.error().describe());
  std::printf(
      "scanned %zu frames on %s: %zu fused, %zu lost, %zu recoveries, %.2f ICP iterations/frame, "
      "%.1f fps",
      stats.frames, rec->device().name.c_str(), stats.fused, stats.lost, stats.recoveries,
      stats.mean_icp_iterations, stats.fps);
  if (summary.contains("ate"))
    std::printf(", ATE %.1f mm", 1000 * summary["ate"]["rmse"].get<double>());
  std::printf("\n%s\n", mesh_line.c_str());
  return exit_code;
}
