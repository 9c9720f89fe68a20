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
    return bad("intrinsics size " + std::to_string(k.width) + "x" + std::to_string(k.height) +
               " is empty");
  if (!(k.fx > 0 && k.fy > 0 && std::isfinite(k.cx) && std::isfinite(k.cy)))
    return bad("intrinsics need positive focal lengths and a finite principal point");
  IMUFUSION_RETURN_IF_ERROR(preprocess.validate());
  IMUFUSION_RETURN_IF_ERROR(icp.validate(preprocess.levels));
  if (tracking.recovery_frames < 1)
    return bad("tracking.recovery_frames must be at least 1, got " +
               std::to_string(tracking.recovery_frames));
  if (tracking.relocalized_recovery_frames < 1 ||
      tracking.relocalized_recovery_frames > tracking.recovery_frames)
    return bad("tracking.relocalized_recovery_frames must be from 1 to recovery_frames (" +
               std::to_string(tracking.recovery_frames) + "), got " +
               std::to_string(tracking.relocalized_recovery_frames));
  if (tracking_level < -1 || tracking_level >= preprocess.levels)
    return bad("tracking_level must be -1 (by device) or a pyramid level below " +
               std::to_string(preprocess.levels) + ", got " + std::to_string(tracking_level));
  if (reference_frames < 0)
    return bad("reference_frames must be 0 (by device) or at least 1, got " +
               std::to_string(reference_frames));
  if (!(reference_motion_pixels >= 0 && std::isfinite(reference_motion_pixels)))
    return bad("reference_motion_pixels must be finite and non-negative, got " +
               std::to_string(reference_motion_pixels));
  if (tracking.prediction_window < 0)
    return bad("tracking.prediction_window must be non-negative, got " +
               std::to_string(tracking.prediction_window));
  if (tracking.restart_lost_frames < 0 || tracking.restart_model_frames < 0)
    return bad("tracking.restart_lost_frames and restart_model_frames must be non-negative, got " +
               std::to_string(tracking.restart_lost_frames) + " and " +
               std::to_string(tracking.restart_model_frames));
  if (tracking.constant_velocity_pairs < 0)
    return bad("tracking.constant_velocity_pairs must be non-negative, got " +
               std::to_string(tracking.constant_velocity_pairs));
  if (tracking.pairing_window < 0)
    return bad("tracking.pairing_window must be non-negative, got " +
               std::to_string(tracking.pairing_window));
  if (!(tracking.pairing_ratio >= 0 && tracking.pairing_ratio <= 1))
    return bad("tracking.pairing_ratio must be in [0, 1], got " +
               std::to_string(tracking.pairing_ratio));
  if (!(tracking.pairing_floor >= 0 && tracking.pairing_floor <= 1))
    return bad("tracking.pairing_floor must be in [0, 1], got " +
               std::to_string(tracking.pairing_floor));
  if (recovery.icp_iterations < 1 || recovery.icp_iterations > 100)
    return bad("recovery.icp_iterations must be 1..100, got " +
               std::to_string(recovery.icp_iterations));
  if (imu.enabled) IMUFUSION_RETURN_IF_ERROR(inertial.validate());
  if (!(recovery.converged_rotation > 0 && recovery.converged_translation > 0))
    return bad("recovery convergence thresholds must be positive");
  const RelocalizationConfig& r = relocalization;
  if (r.interval < 1)
    return bad("relocalization.interval must be at least 1, got " + std::to_string(r.interval));
  if (r.candidates < 1 || r.candidates > 16)
    return bad("relocalization.candidates must be 1..16, got " + std::to_string(r.candidates));
  if (!(r.cell > 0 && r.cell <= 1))
    return bad("relocalization.cell must be in (0, 1] m, got " + std::to_string(r.cell));
  if (!(r.max_radius >= 0 && r.max_radius <= 10))
    return bad("relocalization.max_radius must be 0..10 m, got " + std::to_string(r.max_radius));
  if (!(r.turn_step_deg >= 0 && r.turn_step_deg <= 90))
    return bad("relocalization.turn_step_deg must be 0..90 deg, got " +
               std::to_string(r.turn_step_deg));
  if (!(r.turned_condition_factor > 0 && r.turned_condition_factor <= 1))
    return bad("relocalization.turned_condition_factor must be in (0, 1], got " +
               std::to_string(r.turned_condition_factor));
  if (smoothing.retrack_frames < 0 || smoothing.retrack_frames > 100000)
    return bad("smoothing.retrack_frames must be 0..100000, got " +
               std::to_string(smoothing.retrack_frames));
  const std::pair<const char*, double> non_negative[] = {
      {"imu.max_partial_seconds", imu.max_partial_seconds},
      {"tracking.residual_ratio", tracking.residual_ratio},
      {"imu.seed_reach_pixels", imu.seed_reach_pixels},
      {"relocalization.drift_acceleration", r.drift_acceleration},
      {"relocalization.near_fit_condition_factor", r.near_fit_condition_factor},
      {"relocalization.rival_residual_ratio", r.rival_residual_ratio},
      {"relocalization.rival_inlier_ratio", r.rival_inlier_ratio},
      {"relocalization.max_translation_condition", r.max_translation_condition},
      {"smoothing.partial_move_sigma", smoothing.partial_move_sigma},
      {"smoothing.retracked_frame_sigma", smoothing.retracked_frame_sigma},
      {"recovery.agreement_distance", recovery.agreement_distance}};
  for (const auto& [name, value] : non_negative)
    if (!(value >= 0) || !std::isfinite(value))
      return bad(std::string(name) + " must be finite and >= 0, got " + std::to_string(value));
  for (const double scale : {smoothing.gyro_bias_sigma_scale, smoothing.gravity_sigma_scale})
    if (!(scale > 0) || !std::isfinite(scale))
      return bad("smoothing: drift sigma scales must be finite and positive, got " +
                 std::to_string(scale));
  const Eigen::Matrix4d m = initial_pose.matrix();
  if (!m.allFinite() ||
      (initial_pose.linear().transpose() * initial_pose.linear() - Eigen::Matrix3d::Identity())
              .norm() > 1e-6)
    return bad("initial_pose is not a finite rigid transform");
  return {};
}

}  // namespace imufusion
