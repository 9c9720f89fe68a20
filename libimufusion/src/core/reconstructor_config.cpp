#include <cmath>
#include <string>
#include <utility>

#include "imufusion/reconstructor.hpp"

namespace imufusion {

Status ReconstructorConfig::validate() const {
  auto bad = [](const std::string& message) {
    return make_error(ErrorCode::kInvalidArgument, "reconstructor: " + message);
  };
  const Intrinsics& k = intrinsics;
  if (k.width <= 0 || k.height <= 0)
    return bad("intrinsics size " + std::to_string(k.width) + "x" + std::to_string(k.height) + " is empty");
  if (!(k.fx > 0 && k.fy > 0 && std::isfinite(k.cx) && std::isfinite(k.cy)))
    return bad("intrinsics need positive focal lengths and a finite principal point");
  IMUFUSION_RETURN_IF_ERROR(preprocess.validate());
  IMUFUSION_RETURN_IF_ERROR(icp.validate(preprocess.levels));
  if (tracking.recovery_frames < 1)
    return bad("tracking.recovery_frames must be at least 1, got " + std::to_string(tracking.recovery_frames));
  if (tracking.prediction_window < 0)
    return bad("tracking.prediction_window must be non-negative, got " + std::to_string(tracking.prediction_window));
  if (tracking.pairing_window < 0)
    return bad("tracking.pairing_window must be non-negative, got " + std::to_string(tracking.pairing_window));
  if (!(tracking.pairing_ratio >= 0 && tracking.pairing_ratio <= 1))
    return bad("tracking.pairing_ratio must be in [0, 1], got " + std::to_string(tracking.pairing_ratio));
  if (!(tracking.pairing_floor >= 0 && tracking.pairing_floor <= 1))
    return bad("tracking.pairing_floor must be in [0, 1], got " + std::to_string(tracking.pairing_floor));
  if (tracking.recovery_icp_iterations < 1 || tracking.recovery_icp_iterations > 100)
    return bad("tracking.recovery_icp_iterations must be 1..100, got " +
               std::to_string(tracking.recovery_icp_iterations));
  if (use_imu) IMUFUSION_RETURN_IF_ERROR(inertial.validate());
  if (!(recovery_converged_rotation > 0 && recovery_converged_translation > 0))
    return bad("recovery convergence thresholds must be positive");
  if (relocalization_interval < 1)
    return bad("relocalization_interval must be at least 1, got " + std::to_string(relocalization_interval));
  if (relocalization_candidates < 1 || relocalization_candidates > 16)
    return bad("relocalization_candidates must be 1..16, got " + std::to_string(relocalization_candidates));
  if (!(relocalization_cell > 0 && relocalization_cell <= 1))
    return bad("relocalization_cell must be in (0, 1] m, got " + std::to_string(relocalization_cell));
  if (!(relocalization_max_radius >= 0 && relocalization_max_radius <= 10))
    return bad("relocalization_max_radius must be 0..10 m, got " + std::to_string(relocalization_max_radius));
  if (retrack_lost_frames < 0 || retrack_lost_frames > 100000)
    return bad("retrack_lost_frames must be 0..100000, got " + std::to_string(retrack_lost_frames));
  const std::pair<const char*, double> non_negative[] = {
      {"max_partial_seconds", max_partial_seconds},
      {"relocalization_drift_acceleration", relocalization_drift_acceleration},
      {"partial_move_sigma", partial_move_sigma},
      {"retracked_frame_sigma", retracked_frame_sigma},
      {"recovery_agreement_distance", recovery_agreement_distance},
      {"imu_seed_reach_pixels", imu_seed_reach_pixels}};
  for (const auto& [name, value] : non_negative)
    if (!(value >= 0) || !std::isfinite(value))
      return bad(std::string(name) + " must be finite and >= 0, got " + std::to_string(value));
  for (const double scale : {drift_gyro_bias_sigma_scale, drift_gravity_sigma_scale})
    if (!(scale > 0) || !std::isfinite(scale))
      return bad("drift sigma scales must be finite and positive, got " + std::to_string(scale));
  const Eigen::Matrix4d m = initial_pose.matrix();
  if (!m.allFinite() ||
      (initial_pose.linear().transpose() * initial_pose.linear() - Eigen::Matrix3d::Identity()).norm() > 1e-6)
    return bad("initial_pose is not a finite rigid transform");
  return {};
}

}  // namespace imufusion
