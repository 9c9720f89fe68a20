#include "core/state_fields.hpp"

namespace imufusion {

void describe(StateArchive& a, Intrinsics& x) {
  a(x.fx, x.fy, x.cx, x.cy, x.width, x.height);
  for (double& c : x.distortion) a(c);
}

void describe(StateArchive& a, PreprocessConfig& x) {
  a(x.levels, x.min_depth, x.max_depth, x.bilateral_radius, x.bilateral_sigma_space,
    x.bilateral_sigma_depth, x.max_jump_fraction, x.workgroup_x, x.workgroup_y);
}

void describe(StateArchive& a, NormalGate& x) { a(x.noise_k, x.max_angle_deg); }

void describe(StateArchive& a, IcpReliabilityThresholds& x) {
  a(x.max_condition, x.max_residual_per_weight, x.min_inlier_fraction, x.min_pixel_fraction,
    x.min_inliers);
}

void describe(StateArchive& a, DepthNoiseModel& x) { a(x.a, x.b, x.z0); }

void describe(StateArchive& a, IcpPhotometricConfig& x) {
  a(x.weight, x.huber_sigmas, x.initial_huber, x.pixel_step, x.min_sigma);
}

void describe(StateArchive& a, IcpConfig& x) {
  a(x.iterations_per_level, x.max_total_iterations, x.max_unsettled_iterations, x.settled_chi2,
    x.max_distance, x.max_normal_angle_deg, x.normal_gate, x.converged_rotation,
    x.converged_translation, x.reliability, x.depth_noise, x.keep_seed_in_degenerate_directions,
    x.min_constrained_directions, x.partial_min_fraction, x.seed_sigma_rotation,
    x.seed_sigma_translation, x.seed_gate_condition, x.seed_gate_sigmas, x.seed_gate_hold_sigmas,
    x.seed_gate, x.seed_prior, x.correlated_pixels, x.seed_agreement_chi2, x.photometric);
}

void describe(StateArchive& a, VolumeConfig& x) {
  a(x.voxel_size, x.truncation_voxels, x.max_weight, x.block_capacity, x.hash_slots);
}

void describe(StateArchive& a, TrackingConfig& x) {
  a(x.recovery_frames, x.relocalized_recovery_frames, x.pairing_window, x.pairing_ratio,
    x.pairing_floor, x.prediction_window, x.constant_velocity_pairs, x.restart_lost_frames,
    x.restart_model_frames, x.residual_ratio);
}

void describe(StateArchive& a, InertialConfig& x) {
  a(x.T_camera_imu, x.T_camera_imu_known, x.estimate_gyro_bias, x.initial_gyro_bias, x.translation,
    x.max_extrapolation, x.max_sample_gap, x.sample_history, x.gyro_bias_prior_sigma,
    x.gyro_bias_random_walk, x.gyro_noise_density, x.icp_rotation_sigma, x.hand_eye_min_pairs,
    x.hand_eye_max_sigma_deg, x.hand_eye_max_pairs, x.mounting_check_deg, x.tracking_position_sigma,
    x.constant_velocity_process_noise, x.accelerometer_process_noise, x.max_velocity_sigma,
    x.accelerometer_dead_reckoning_time, x.velocity_decay_time, x.max_speed, x.gravity_min_time,
    x.gravity_time_constant, x.gravity_chain_time, x.accelerometer_bias_prior_sigma);
}

void describe(StateArchive& a, ImuAidConfig& x) {
  a(x.enabled, x.seed_reach_pixels, x.prior, x.partial_icp, x.seed_gate, x.max_partial_seconds);
}

void describe(StateArchive& a, RelocalizationConfig& x) {
  a(x.enabled, x.interval, x.cell, x.candidates, x.drift_acceleration, x.max_radius,
    x.near_fit_condition_factor, x.turn_step_deg, x.rival_residual_ratio, x.rival_inlier_ratio,
    x.max_translation_condition, x.turned_condition_factor);
}

void describe(StateArchive& a, RecoveryConfig& x) {
  a(x.icp_iterations, x.converged_rotation, x.converged_translation, x.agreement_distance,
    x.correct_velocity, x.partial_without_imu);
}

void describe(StateArchive& a, LossSmoothingConfig& x) {
  a(x.gyro_bias_sigma_scale, x.gravity_sigma_scale, x.retrack_frames, x.retracked_frame_sigma,
    x.partial_move_sigma);
}

void describe(StateArchive& a, ReconstructorConfig& x) {
  a(x.intrinsics, x.preprocess, x.icp, x.volume, x.tracking, x.inertial, x.imu, x.relocalization,
    x.recovery, x.smoothing, x.tracking_level, x.reference_frames, x.reference_motion_pixels,
    x.initial_pose);
}

void describe(StateArchive& a, ImuSample& x) { a(x.timestamp, x.gyro, x.accel); }

void describe(StateArchive& a, StampedPose& x) { a(x.timestamp, x.T_world_camera); }

void describe(StateArchive& a, DriftPrior& x) {
  a(x.gravity_world, x.velocity_sigma, x.gravity_bias_covariance, x.gyro_bias_sigma,
    x.gyro_noise_density);
}

void describe(StateArchive& a, DepthView& x) {
  a(x.width, x.height, x.format, x.depth_scale);
  if (a.reading()) x = DepthView{nullptr, x.width, x.height, 0, x.format, x.depth_scale, 0};
}

}  // namespace imufusion
