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
// all of the IMU (frame_step.hpp). The command line is in scan_options.hpp, summary.json in
// scan_summary.hpp; known-pose fusion and the model's outputs (mesh, preview, overview) are
// shared with imufusion-fuse (model_outputs.hpp).

#include <unistd.h>

#include <algorithm>
#include <chrono>
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

#include "cli_common.hpp"
#include "cli_numbers.hpp"
#include "demo_sequence.hpp"
#include "frame_step.hpp"
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
#include "model_outputs.hpp"
#include "scan_live.hpp"
#include "scan_options.hpp"
#include "scan_summary.hpp"

namespace fs = std::filesystem;
using namespace imufusion;

namespace {

using tools::fail;
using tools::ms_since;
using tools::print_devices;

using tools::ScanOptions;
using tools::ScanRun;

// The signal that asked the scan to stop (SIGINT or SIGTERM), 0 while none did: the scan ends
// after its current frame and writes every output, as at the end of the input.
volatile std::sig_atomic_t g_interrupted = 0;
void on_interrupt(int signal) { g_interrupted = signal; }

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
std::string sequence_imu_unusable(const ScanOptions& opt, const SequenceReader* reader) {
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
ReconstructorConfig make_config(const ScanOptions& opt, const SequenceReader* reader,
                                const FrameSource* source, const Intrinsics& k, bool sequence_imu) {
  const bool with_imu =
      !opt.no_imu && (opt.imu_udp || (reader != nullptr && reader->has_imu() && sequence_imu));
  Intrinsics lens = k;
  if (opt.distortion) lens.distortion = *opt.distortion;
  ReconstructorConfig config = preset_config(opt.sensor, lens, with_imu);
  if (opt.voxel_size) config.volume.voxel_size = *opt.voxel_size;
  config.volume.block_capacity = opt.block_capacity;
  config.volume.initial_blocks = opt.initial_blocks;
  config.tracking_level = opt.tracking_level;
  config.reference_frames = opt.reference_frames;
  // The hash table keeps at least 4 slots per block, as the defaults do.
  while (config.volume.hash_slots < 4ull * opt.block_capacity) config.volume.hash_slots *= 2;
  config.device.selector = opt.device;
  if (opt.icp_iterations) {
    config.icp.max_total_iterations = *opt.icp_iterations;
    config.icp.max_unsettled_iterations = 0;
  }
  if (opt.photometric_weight) config.icp.photometric.weight = *opt.photometric_weight;
  config.tracking.recovery_frames = opt.recovery_frames;
  // The default never asks a relocalized frame for more than any other recovering frame.
  config.tracking.relocalized_recovery_frames = opt.relocalized_recovery_frames.value_or(
      std::min(TrackingConfig{}.relocalized_recovery_frames, opt.recovery_frames));
  if (source != nullptr && source->T_camera_imu()) {
    config.inertial.T_camera_imu = *source->T_camera_imu();
    config.inertial.T_camera_imu_known = true;
  }
  if (reader != nullptr) apply_sequence_calibration(*reader, config);
  if (opt.estimate_imu_rotation) {
    config.inertial.T_camera_imu = Eigen::Isometry3d::Identity();
    config.inertial.T_camera_imu_known = false;
  }
  if (opt.translation) config.inertial.translation = *opt.translation;
  return config;
}

// The outputs of a scan, replaced as one set; summary.json, last, marks the set complete.
std::vector<std::string> scan_outputs() {
  std::vector<std::string> names = {"trajectory.txt", "frames.csv"};
  names.insert(names.end(), std::begin(tools::kModelOutputs), std::end(tools::kModelOutputs));
  names.push_back("summary.json");
  return names;
}

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
    auto pictures_ms =
        tools::write_model_outputs(set, rec, *mesh, tools::path_of(rec.trajectory(), run.lost_at));
    if (!pictures_ms) return pictures_ms.error();
    summary["pictures_ms"] = *pictures_ms;
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
Result<SessionRecorder> open_recorder(const ScanOptions& opt, const ReconstructorConfig& c,
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
std::string open_input(const ScanOptions& opt, const fs::path& input, ScanInput& in) {
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
std::size_t frame_limit(const ScanOptions& opt) {
  return opt.max_frames > 0 ? static_cast<std::size_t>(opt.max_frames) : SIZE_MAX;
}

// One frame tracked and fused, or fused at its pose from --poses (nullopt: --poses has none).
Result<std::optional<FrameResult>> scan_one(const ScanOptions& opt, Reconstructor& rec,
                                            const Trajectory& known, const Frame& frame) {
  if (!opt.poses.empty()) return tools::fuse_at_known_pose(rec, known, frame);
  auto result = rec.track_and_fuse(frame.timestamp, frame.depth,
                                   frame.color ? &*frame.color : nullptr, frame.imu);
  if (!result) return result.error();
  return std::optional<FrameResult>(std::move(*result));
}

// Warns, once, when the given IMU mounting disagrees with the motion (InertialStatus).
void warn_mounting(const InertialStatus& in, bool progress, ScanRun& run) {
  if (!in.R_camera_imu_disagrees || run.mounting_warned) return;
  run.mounting_warned = true;
  char angle[32];
  std::snprintf(angle, sizeof angle, "%.0f", in.R_camera_imu_disagreement_deg);
  std::cerr << (progress ? "\n" : "") << "warning: the given IMU mounting (imu_to_camera.txt, "
            << "T_camera_imu) disagrees with the motion by " << angle
            << " deg: it is probably wrong; --estimate-imu-rotation estimates it from the scan\n";
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

// After the last frame: --save-state (before finish(), which would settle a recovery the
// continued scan may still complete), then finish().
void end_scan(const ScanOptions& opt, Reconstructor& rec, ScanRun& run, int& exit_code) {
  // Before finish() and the pictures raycast again.
  if (auto steps = rec.raycast_steps_per_ray()) run.raycast_steps_per_ray = *steps;
  if (!opt.save_state.empty()) {
    const auto t0 = std::chrono::steady_clock::now();
    if (const Status saved = rec.save(opt.save_state); !saved) {
      std::cerr << "error: --save-state: " << saved.error().describe() << "\n";
      exit_code = 1;
    } else if (!opt.quiet) {
      std::cerr << "state: " << rec.trajectory().size() << " frames, " << rec.allocated_blocks()
                << " blocks saved to " << opt.save_state.string() << " in " << ms_since(t0)
                << " ms\n";
    }
  }
  auto placed = rec.finish();
  if (placed) {
    run.summary.add_retracked(*placed);
  } else if (run.stopped.empty()) {
    run.stopped = "ending the scan: " + placed.error().describe();
    exit_code = 1;
  }
}

// Scans until the input ends, --frames frames are done, a frame fails or SIGINT/SIGTERM, then
// settles a scan that ends while recovering (Reconstructor::finish). Returns the exit code.
int scan_frames(const ScanOptions& opt, Reconstructor& rec, ScanInputs in, ScanRun& run) {
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
    if (std::string(tools::tracking_state(**result)) != "tracking")
      run.lost_at.push_back((*result)->timestamp);
    warn_mounting((*result)->inertial, progress, run);
    run.summary.add(**result);
    run.last = std::move(**result);
    const double frames_done = static_cast<double>(run.summary.frames());
    if (progress) show_progress(i + 1, in.total, *run.last, 1000.0 * frames_done / elapsed_ms);
  }
  if (progress) std::fputc('\n', stderr);
  if (run.last) end_scan(opt, rec, run, exit_code);
  return exit_code;
}

// The sequence's intrinsics (at its images' size), or the source's.
Intrinsics input_intrinsics(const ScanInput& in) {
  if (!in.reader) return in.source->intrinsics();
  Intrinsics k = *in.reader->intrinsics();
  k.width = in.reader->info().width;
  k.height = in.reader->info().height;
  return k;
}

// Warns of the samples the sequence's imu.txt left out (io/imu_gate.hpp).
void warn_imu_left_out(const SequenceReader* sequence) {
  if (sequence == nullptr ||
      (sequence->info().imu_implausible == 0 && sequence->info().imu_time_jumps == 0))
    return;
  std::cerr << "warning: " << (sequence->info().directory / "imu.txt").string() << ": left out "
            << sequence->info().imu_implausible << " samples beyond a real IMU's range and "
            << sequence->info().imu_time_jumps << " jumps in time\n";
}

// The live inputs of a scan, each optional: the UDP IMU stream (--imu-udp) and the session
// recorder (--record).
struct LiveInputs {
  std::optional<tools::LiveImu> imu;
  std::optional<SessionRecorder> recorder;
};

// Opens --imu-udp and --record into `live`; returns the error message, empty on success.
std::string open_live(const ScanOptions& opt, const Reconstructor& rec,
                      const SequenceReader* sequence, LiveInputs& live) {
  if (opt.imu_udp) {
    auto opened = tools::LiveImu::open(*opt.imu_udp, opt.imu_udp_address);
    if (!opened) return opened.error().describe();
    live.imu.emplace(std::move(*opened));
  }
  if (!opt.record.empty()) {
    auto opened = open_recorder(opt, rec.config(), sequence);
    if (!opened) return opened.error().describe();
    live.recorder.emplace(std::move(*opened));
  }
  if (live.imu && !opt.quiet)
    std::cerr << "imu: listening on " << live.imu->endpoint() << std::endl;
  return {};
}

// Ends --record after the scan: returns its report for summary.json; a failure to finish the
// recording turns exit code 0 into 1.
nlohmann::json finish_recording(const ScanOptions& opt, LiveInputs& live, int& exit_code) {
  if (!live.recorder) return {};
  if (live.imu) live.recorder->set_imu_clock_offset(live.imu->imu_to_frame_offset());
  const Status finished = live.recorder->finish();
  if (!finished) {
    std::cerr << "error: recording into " << opt.record.string() << ": "
              << finished.error().describe() << "\n";
    if (exit_code == 0) exit_code = 1;
  }
  return tools::recorder_report(*live.recorder, finished);
}

// Writes the outputs, puts them in place and prints the scan's figures; returns the exit code,
// `exit_code` when all was written.
int write_and_report(const ScanOptions& opt, io::OutputSet& outputs, Reconstructor& rec,
                     ScanRun& run, const ScanStatistics& stats, const nlohmann::json& summary,
                     int exit_code) {
  std::string mesh_line;
  if (auto s = write_outputs(outputs, rec, run, summary, &mesh_line); !s) {
    return fail(s.error().describe() + " (the outputs of an earlier run in " + opt.out.string() +
                " are as they were)");
  }
  if (auto s = outputs.commit(); !s) return fail(s.error().describe());
  std::printf(
      "scanned %zu frames on %s: %zu fused, %zu lost, %zu recoveries, %.2f ICP iterations/frame, "
      "%.1f fps",
      stats.frames, rec.device().name.c_str(), stats.fused, stats.lost, stats.recoveries,
      stats.mean_icp_iterations, stats.fps);
  if (summary.contains("ate"))
    std::printf(", ATE %.1f mm", 1000 * summary["ate"]["rmse"].get<double>());
  std::printf("\n%s\n", mesh_line.c_str());
  return exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  ScanOptions opt;
  if (const int rc = tools::parse_scan_options(argc, argv, opt); rc >= 0) return rc;
  if (opt.list_devices) return print_devices();

  fs::path input = opt.input;
  if (input.empty()) {
    auto demo = tools::ensure_demo_sequence(opt.demo_dir, opt.demo_frames, opt.sensor);
    if (!demo) return fail(demo.error().describe());
    input = *demo;
  }
  ScanInput in;
  if (const std::string error = open_input(opt, input, in); !error.empty()) return fail(error);
  Trajectory known;
  if (!opt.poses.empty()) {
    auto read = read_trajectory(opt.poses);
    if (!read) return fail(read.error().describe());
    known = std::move(*read);
  }
  // --out is checked before the scan: a live scan must not find it unwritable at the end.
  auto outputs = io::OutputSet::begin(opt.out, scan_outputs());
  if (!outputs) return fail(outputs.error().describe());
  const SequenceReader* sequence = in.reader ? &*in.reader : nullptr;
  ScanRun run;
  run.frames_csv = outputs->staged("frames.csv");
  run.imu_fallback = sequence_imu_unusable(opt, sequence);
  if (!run.imu_fallback.empty()) std::cerr << "warning: " << run.imu_fallback << "\n";
  warn_imu_left_out(sequence);
  DeviceOptions device;
  device.selector = opt.device;
  const auto t0 = std::chrono::steady_clock::now();
  auto rec =
      opt.resume.empty()
          ? Reconstructor::create(make_config(opt, sequence, in.source.get(), input_intrinsics(in),
                                              run.imu_fallback.empty()))
          : Reconstructor::load(opt.resume, device);
  if (!rec) return fail(rec.error().describe());
  if (!opt.resume.empty() && !opt.quiet)
    std::cerr << "state: " << rec->trajectory().size() << " frames loaded from "
              << opt.resume.string() << " in " << ms_since(t0) << " ms\n";
  LiveInputs live;
  if (const std::string error = open_live(opt, *rec, sequence, live); !error.empty())
    return fail(error);

  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  const std::size_t limit = frame_limit(opt);
  tools::SteppedFrames frames(in.source ? nullptr : &*in.reader, in.source.get(), opt.frame_step);
  const std::size_t resumed = opt.resume.empty() || rec->trajectory().empty()
                                  ? 0
                                  : frames.skip_through(rec->trajectory().back().timestamp);
  const std::size_t total =
      in.reader ? std::min(frames.kept_of(in.reader->frame_count()) - resumed, limit)
                : (opt.max_frames > 0 ? limit : 0);
  int exit_code =
      scan_frames(opt, *rec, ScanInputs{frames, total, live.imu, live.recorder, known}, run);
  if (!run.stopped.empty())
    std::cerr << (exit_code > 128 ? "stopped: " : "error: ") << run.stopped << "\n";
  const nlohmann::json recording = finish_recording(opt, live, exit_code);
  if (!run.last) return fail("no frame was scanned; nothing written");

  const ScanStatistics stats = run.summary.statistics();
  nlohmann::json summary = tools::summary_json(opt, *rec, run, stats, sequence, input.string());
  if (live.imu) summary["imu_stream"] = live.imu->report();
  if (live.recorder) summary["recording"] = recording;
  return write_and_report(opt, *outputs, *rec, run, stats, summary, exit_code);
}
