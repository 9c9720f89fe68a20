#pragma once
// What a scan reports about itself: frames.csv (one row per frame) and the summary figures
// (lost frames, recoveries, ICP iterations, frame rate) that imufusion-scan and the benchmarks
// print and store.

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "imufusion/reconstructor.hpp"
#include "imufusion/result.hpp"

namespace imufusion {

/// The header of frames.csv. Columns: timestamp (s), status, pose_source, icp_iterations
/// (Gauss-Newton steps run for the frame, all levels), residual (r, m^2), inliers (n),
/// weight_sum, condition (kappa), fused (0/1), ms (wall time of the frame), then icp_reliable,
/// icp_reason, icp_directions (of the 6, those ICP updated), relocalized (0/1: the pose came
/// from the relocalization search), recovery_restarted (0/1: this recovering frame disagreed
/// with the ones before it and started the recovery's count again), imu_rotation (0/1: the
/// seed's rotation came from the gyro), imu_coverage, gyro_bias_x/y/z (rad/s),
/// R_camera_imu_estimated, R_camera_imu_sigma_deg, blocks (allocated after the frame),
/// pool_full (blocks the frame touched that the full block pool had no room for: not fused),
/// tx ty tz qx qy qz qw (T_world_camera).
std::string frames_csv_header();
/// One row of frames.csv (no newline). Quality columns are empty when ICP did not run.
std::string frames_csv_row(const FrameResult& frame, std::uint32_t allocated_blocks);

struct ScanStatistics {
  std::size_t frames = 0;
  std::size_t fused = 0;
  std::size_t lost = 0;               // frames with status lost
  std::size_t recovering = 0;         // frames with status recovering
  std::size_t recoveries = 0;         // losses that ended in tracking again
  std::size_t broken_recoveries = 0;  // recovering frames followed by a lost one
  std::size_t dead_reckoned = 0;
  std::size_t partial = 0;  // frames with pose source icp_partial (degenerate depth, IMU-aided)
  std::size_t relocalizations = 0;    // frames placed by the relocalization search
  std::size_t recovery_restarts = 0;  // recovering frames that started the count again
  std::size_t restarts = 0;           // frames the scan started again at (FrameResult::restarted)
  std::size_t retracked = 0;          // lost frames placed by ICP backward from their recovery
  std::size_t new_references = 0;     // frames after which the model was raycast as the reference
  /// Fused frames with blocks the full block pool had no room for (partly fused), and the
  /// index of the first (when pool_full_frames > 0).
  std::size_t pool_full_frames = 0;
  std::size_t first_pool_full_frame = 0;
  double mean_icp_iterations = 0;    // over frames where ICP ran
  double median_icp_iterations = 0;  // over frames where ICP ran
  /// Over tracking frames where ICP ran: the paper's per-frame figure. Lost and recovering
  /// frames run the recovery's budget (RecoveryConfig::icp_iterations) while they look
  /// for the model, so a scan lost much of the time has a higher median over all frames.
  double median_icp_iterations_tracking = 0;
  double mean_frame_ms = 0;
  double median_frame_ms = 0;
  double fps = 0;  // frames / total frame time
  /// Mean wall time per frame of each stage (ms, over all frames; total_ms is the whole frame).
  FrameTimings mean_stage_ms;
  /// Mean GPU time per frame of each kernel (timestamp queries, ms, a frame's dispatches of the
  /// kernel summed), with the mean number of its dispatches per frame; slowest first.
  struct KernelShare {
    std::string kernel;  // shader name and pyramid level, e.g. "bilateral[0]"
    double gpu_ms = 0;
    double dispatches = 0;
  };
  std::vector<KernelShare> mean_kernels;
  /// Frames from the end of each loss (first lost frame) to the frame that resumed tracking.
  std::vector<std::size_t> recovery_frames;
};

ScanStatistics summarize_scan(const std::vector<FrameResult>& frames);

/// summarize_scan one frame at a time, for a scan that does not keep its frames: 12 bytes a
/// frame (for the medians).
class ScanSummary {
 public:
  void add(const FrameResult& frame);
  /// Frames placed backward after the last add() (Reconstructor::finish()).
  void add_retracked(std::size_t frames);
  std::size_t frames() const { return statistics_.frames; }
  ScanStatistics statistics() const;

 private:
  void add_stage_times(const FrameTimings& timings);

  ScanStatistics statistics_;  // the counts; means, medians and fps at statistics()
  std::vector<float> iterations_, tracking_iterations_, ms_;
  double total_ms_ = 0;
  FrameTimings stage_sums_;  // kernels unused: kernel_sums_ holds them
  std::map<std::string, ScanStatistics::KernelShare> kernel_sums_;
  bool in_loss_ = false;
  std::size_t loss_start_ = 0;
  TrackingStatus previous_status_ = TrackingStatus::kTracking;
};

}  // namespace imufusion
