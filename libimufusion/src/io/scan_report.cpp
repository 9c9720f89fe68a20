#include "imufusion/scan_report.hpp"

#include <algorithm>
#include <cstdio>
#include <string>

namespace imufusion {
namespace {

std::string format(const char* fmt, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, fmt, value);
  return buffer;
}

// The reason may hold commas; frames.csv keeps one field per column.
std::string csv_field(std::string text) {
  std::replace(text.begin(), text.end(), ',', ';');
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

double median_of(std::vector<float> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace

std::string frames_csv_header() {
  return "timestamp,status,pose_source,icp_iterations,residual,inliers,weight_sum,condition,fused,"
         "ms,"
         "icp_reliable,icp_reason,icp_directions,imu_disagreement,imu_chi2,imu_agreed,inlier_"
         "fraction,pixel_fraction,covered_fraction,covered_inlier_fraction,relocalized,recovery_"
         "restarted,imu_rotation,imu_coverage,gyro_"
         "bias_x,gyro_bias_y,gyro_bias_z,"
         "R_camera_imu_estimated,R_camera_imu_sigma_deg,blocks,pool_full,tx,ty,tz,qx,qy,qz,qw";
}

std::string frames_csv_row(const FrameResult& f, std::uint32_t allocated_blocks) {
  std::string row = format("%.6f", f.timestamp);
  row += std::string(",") + to_string(f.status) + "," + to_string(f.source) + ",";
  if (f.icp_ran) {
    const IcpQuality& q = f.icp.quality;
    row += std::to_string(q.iterations) + "," + format("%.6g", q.residual) + "," +
           std::to_string(q.inliers) + "," + format("%.6g", q.weight_sum) + "," +
           format("%.6g", q.condition);
  } else {
    row += ",,,,";
  }
  row += std::string(",") + (f.fused ? "1" : "0") + "," + format("%.2f", f.timings.total_ms) + ",";
  row += f.icp_ran ? std::string(f.icp.reliable() ? "1" : "0") + "," + csv_field(f.icp.reason) +
                         "," + std::to_string(f.icp.quality.constrained_directions) + "," +
                         format("%.3g", f.icp.quality.seed_disagreement) + "," +
                         format("%.3g", f.icp.quality.seed_chi2) + "," +
                         (f.icp.quality.agreed_with_seed ? "1" : "0") + "," +
                         format("%.3f", f.icp.quality.inlier_fraction) + "," +
                         format("%.3f", f.icp.quality.pixel_fraction) + "," +
                         format("%.3f", f.icp.quality.covered_fraction) + "," +
                         format("%.3f", f.icp.quality.covered_inlier_fraction)
                   : std::string(",,,,,,,,,");
  row += std::string(",") + (f.relocalized ? "1" : "0") + "," + (f.recovery_restarted ? "1" : "0");
  row += std::string(",") + (f.imu.rotation_from_imu ? "1" : "0") + "," +
         format("%.3f", f.imu.covered_fraction);
  for (int i = 0; i < 3; ++i) row += "," + format("%.6g", f.inertial.gyro_bias[i]);
  row += std::string(",") + (f.inertial.R_camera_imu_estimated ? "1" : "0") + "," +
         format("%.4g", f.inertial.R_camera_imu_sigma_deg) + "," +
         std::to_string(allocated_blocks) + "," +
         std::to_string(f.fused ? f.integration.pool_full : 0u);
  const Eigen::Vector3d t = f.T_world_camera.translation();
  const Eigen::Quaterniond q(f.T_world_camera.linear());
  for (double v : {t.x(), t.y(), t.z()}) row += "," + format("%.6f", v);
  for (double v : {q.x(), q.y(), q.z(), q.w()}) row += "," + format("%.9f", v);
  return row;
}

void ScanSummary::add(const FrameResult& f) {
  ScanStatistics& s = statistics_;
  const std::size_t i = s.frames++;
  if (f.fused) ++s.fused;
  if (f.status == TrackingStatus::kLost) ++s.lost;
  if (f.status == TrackingStatus::kRecovering) ++s.recovering;
  if (f.source == PoseSource::kDeadReckoning) ++s.dead_reckoned;
  if (f.source == PoseSource::kIcpPartial) ++s.partial;
  if (f.relocalized) ++s.relocalizations;
  if (f.recovery_restarted) ++s.recovery_restarts;
  if (f.restarted) ++s.restarts;
  if (i > 0 && f.status == TrackingStatus::kLost && previous_status_ == TrackingStatus::kRecovering)
    ++s.broken_recoveries;
  previous_status_ = f.status;
  s.retracked += f.retracked;
  if (f.new_reference) ++s.new_references;
  if (f.fused && f.integration.pool_full > 0 && s.pool_full_frames++ == 0)
    s.first_pool_full_frame = i;
  if (f.icp_ran) iterations_.push_back(static_cast<float>(f.icp.quality.iterations));
  if (f.icp_ran && f.status == TrackingStatus::kTracking)
    tracking_iterations_.push_back(static_cast<float>(f.icp.quality.iterations));
  ms_.push_back(static_cast<float>(f.timings.total_ms));
  total_ms_ += f.timings.total_ms;
  add_stage_times(f.timings);
  if (f.status != TrackingStatus::kTracking && !in_loss_) {
    in_loss_ = true;
    loss_start_ = i;
  }
  if (f.recovered) {
    ++s.recoveries;
    if (in_loss_) s.recovery_frames.push_back(i - loss_start_);
    in_loss_ = false;
  }
}

void ScanSummary::add_stage_times(const FrameTimings& t) {
  FrameTimings& sum = stage_sums_;
  sum.preprocess_ms += t.preprocess_ms;
  sum.icp_ms += t.icp_ms;
  sum.integrate_ms += t.integrate_ms;
  sum.raycast_ms += t.raycast_ms;
  sum.relocalize_ms += t.relocalize_ms;
  sum.retrack_ms += t.retrack_ms;
  sum.total_ms += t.total_ms;
  for (const KernelTiming& k : t.kernels) {
    ScanStatistics::KernelShare& share = kernel_sums_[k.kernel];
    share.gpu_ms += std::max(0.0, k.gpu_ms);
    share.dispatches += 1;
  }
}

void ScanSummary::add_retracked(std::size_t frames) { statistics_.retracked += frames; }

ScanStatistics ScanSummary::statistics() const {
  ScanStatistics s = statistics_;
  if (!iterations_.empty()) {
    for (float v : iterations_) s.mean_icp_iterations += v;
    s.mean_icp_iterations /= static_cast<double>(iterations_.size());
    s.median_icp_iterations = median_of(iterations_);
  }
  if (!tracking_iterations_.empty())
    s.median_icp_iterations_tracking = median_of(tracking_iterations_);
  if (!ms_.empty()) {
    s.mean_frame_ms = total_ms_ / static_cast<double>(ms_.size());
    s.median_frame_ms = median_of(ms_);
  }
  s.fps = total_ms_ > 0 ? 1000.0 * static_cast<double>(s.frames) / total_ms_ : 0;
  if (s.frames > 0) {
    const double n = static_cast<double>(s.frames);
    const FrameTimings& sum = stage_sums_;
    FrameTimings& mean = s.mean_stage_ms;
    mean.preprocess_ms = sum.preprocess_ms / n;
    mean.icp_ms = sum.icp_ms / n;
    mean.integrate_ms = sum.integrate_ms / n;
    mean.raycast_ms = sum.raycast_ms / n;
    mean.relocalize_ms = sum.relocalize_ms / n;
    mean.retrack_ms = sum.retrack_ms / n;
    mean.total_ms = sum.total_ms / n;
    for (const auto& [kernel, share] : kernel_sums_)
      s.mean_kernels.push_back({kernel, share.gpu_ms / n, share.dispatches / n});
    std::sort(s.mean_kernels.begin(), s.mean_kernels.end(),
              [](const auto& a, const auto& b) { return a.gpu_ms > b.gpu_ms; });
  }
  return s;
}

ScanStatistics summarize_scan(const std::vector<FrameResult>& frames) {
  ScanSummary summary;
  for (const FrameResult& f : frames) summary.add(f);
  return summary.statistics();
}

}  // namespace imufusion
