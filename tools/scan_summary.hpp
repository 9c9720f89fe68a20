#pragma once
// imufusion-scan's summary.json: what the scan counted, its settings, the IMU's estimates at the
// end and, against the sequence's ground truth, the trajectory's ATE.

#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "imufusion/eval.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/scan_report.hpp"
#include "imufusion/sequence.hpp"
#include "io/line_appender.hpp"
#include "scan_options.hpp"

namespace imufusion::tools {

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
  bool mounting_warned = false;  // the given IMU mounting was reported to disagree
  std::vector<double> lost_at;   // s, the frames whose pose tracking did not give, in order
  std::size_t frames_without_pose = 0;
  std::optional<double> raycast_steps_per_ray;  // of the scan's last model raycast
};

// summary.json's "stage_ms" (mean wall ms per frame of each stage) and "kernel_gpu_ms" (mean GPU
// ms per frame of each kernel, slowest first, with its dispatches per frame).
inline void write_stage_times(const ScanStatistics& stats, nlohmann::json& j) {
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

// summary.json's "imu_estimates": the inertial estimators' state after the last frame.
inline nlohmann::json imu_estimates_json(const InertialStatus& in) {
  nlohmann::json imu;
  imu["gyro_bias"] = {in.gyro_bias.x(), in.gyro_bias.y(), in.gyro_bias.z()};
  imu["gyro_bias_sigma"] = {in.gyro_bias_sigma.x(), in.gyro_bias_sigma.y(), in.gyro_bias_sigma.z()};
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
  if (!in.R_camera_imu_estimated) {
    imu["camera_imu_check"] = {{"disagrees", in.R_camera_imu_disagrees},
                               {"angle_deg", in.R_camera_imu_disagreement_deg},
                               {"R_camera_imu_xyzw",
                                {in.R_camera_imu_check.x(), in.R_camera_imu_check.y(),
                                 in.R_camera_imu_check.z(), in.R_camera_imu_check.w()}}};
  }
  return imu;
}

// summary.json's "settings": how the scan ran (`reader`: the sequence, null for a camera).
inline nlohmann::json scan_settings_json(const ScanOptions& opt, const Reconstructor& rec,
                                         const ScanRun& run, const SequenceReader* reader) {
  const ReconstructorConfig& c = rec.config();
  nlohmann::json s;
  s["mode"] = opt.poses.empty() ? "track" : "known_poses";
  s["frame_step"] = opt.frame_step;
  s["imu"] = c.imu.enabled;
  s["imu_in_sequence"] = reader != nullptr && reader->has_imu();
  if (!run.imu_fallback.empty()) s["imu_fallback"] = run.imu_fallback;
  s["imu_source"] = !c.imu.enabled ? "none" : opt.imu_udp ? "udp" : "sequence";
  s["icp_iterations_cap"] = c.icp.max_total_iterations;
  s["icp_iterations_unsettled"] = c.icp.max_unsettled_iterations;
  const Intrinsics tracked = c.intrinsics.at_level(rec.tracking_level());
  s["tracking_level"] = rec.tracking_level();
  s["tracking_size"] = std::to_string(tracked.width) + "x" + std::to_string(tracked.height);
  s["reference_frames"] = rec.reference_frames();
  s["reference_motion_pixels"] = c.reference_motion_pixels;
  s["lens_distortion"] = c.intrinsics.distortion;  // k1 k2 p1 p2 k3; all 0: a pinhole
  s["recovery_icp_iterations"] = c.recovery.icp_iterations;
  s["recovery_frames"] = c.tracking.recovery_frames;
  s["relocalized_recovery_frames"] = c.tracking.relocalized_recovery_frames;
  s["translation_model"] = to_string(c.inertial.translation);
  s["camera_imu_rotation"] = c.inertial.T_camera_imu_known ? "given" : "estimated";
  s["voxel_size"] = c.volume.voxel_size;
  s["truncation"] = c.volume.truncation();
  s["width"] = c.intrinsics.width;
  s["height"] = c.intrinsics.height;
  return s;
}

// summary.json's counts of the scan's frames by how they were tracked, and the volume's use.
inline void write_frame_counts(const ScanStatistics& stats, const Reconstructor& rec,
                               nlohmann::json& j) {
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
  j["restarts"] = stats.restarts;
  j["retracked_frames"] = stats.retracked;
  j["frames_to_recover"] = stats.recovery_frames;
  j["mean_icp_iterations"] = stats.mean_icp_iterations;
  j["median_icp_iterations"] = stats.median_icp_iterations;
  j["median_icp_iterations_tracking"] = stats.median_icp_iterations_tracking;
  j["fps"] = stats.fps;
  j["median_frame_ms"] = stats.median_frame_ms;
  j["blocks_allocated"] = rec.allocated_blocks();
  j["block_capacity"] = rec.config().volume.block_capacity;
  j["model_raycasts"] = stats.new_references;  // frames that raycast the next reference
  j["pool_full_frames"] = stats.pool_full_frames;
  if (stats.pool_full_frames > 0) j["first_pool_full_frame"] = stats.first_pool_full_frame;
  j["pool_blocks_reserved"] = rec.pool_blocks();
  j["pool_growths"] = rec.pool_growths();
  j["volume_bytes_reserved"] = rec.memory_bytes();
}

// The scan's summary.json, without the mesh's size (write_outputs adds it).
inline nlohmann::json summary_json(const ScanOptions& opt, const Reconstructor& rec,
                                   const ScanRun& run, const ScanStatistics& stats,
                                   const SequenceReader* reader, const std::string& input) {
  nlohmann::json j;
  j["input"] = input;
  j["device"] = rec.device().name;
  write_frame_counts(stats, rec, j);
  write_stage_times(stats, j);
  if (run.raycast_steps_per_ray) j["raycast_steps_per_ray"] = *run.raycast_steps_per_ray;
  if (!run.stopped.empty()) j["stopped_early"] = run.stopped;
  if (run.frames_without_pose > 0) j["frames_without_pose"] = run.frames_without_pose;
  j["settings"] = scan_settings_json(opt, rec, run, reader);
  if (reader != nullptr && reader->has_imu()) {
    j["imu_rejected"] = {{"implausible", reader->info().imu_implausible},
                         {"time_jumps", reader->info().imu_time_jumps}};
  }
  if (run.last && rec.config().imu.enabled)
    j["imu_estimates"] = imu_estimates_json(run.last->inertial);
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

}  // namespace imufusion::tools
