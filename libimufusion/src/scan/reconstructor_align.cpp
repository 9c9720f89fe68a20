// Reconstructor::Impl, the alignment of one frame: ICP's reliability thresholds, first pyramid
// level, budget and seed weights from the IMU's prediction, and the pairing reference the scan's
// first frame sets; and the ModelAligner that relocalization and loss recovery align through.

#include <algorithm>
#include <cmath>
#include <vector>

#include "scan/reconstructor_impl.hpp"

namespace imufusion {

// The first frame against the model it alone made, at its own pose: what an aligned frame of
// this sensor and scene pairs, the pairing reference until tracked frames replace it.
Status Reconstructor::Impl::pair_with_own_model(FrameTimings& timings) {
  gpu::GpuNormalEquationSource source(icp_kernels, icp_seq, current, reference, &timings.kernels,
                                      tracking_level);
  const float min_cos =
      static_cast<float>(std::cos(config.icp.max_normal_angle_deg[0] * M_PI / 180.0));
  auto eq = source.evaluate(0, Eigen::Isometry3d::Identity(), config.icp.max_distance[0], min_cos);
  if (!eq) return eq.error();
  if (eq->valid_pixels > 0 && eq->valid_information > 0)
    pairing.add(eq->inlier_fraction(), eq->pixel_fraction());
  return {};
}

// The second frame is aligned to the first frame's own filtered maps, not to the model raycast:
// a model fused from one raw frame shows its noise, and a frame pairs a fraction of it
// (bench/README.md, "The first alignment against the first frame itself"). model.vertices and
// model.normals take the maps too, the reference a saved scan keeps.
Status Reconstructor::Impl::reference_from_first_frame(FrameTimings& timings) {
  const auto t0 = Clock::now();
  IMUFUSION_RETURN_IF_ERROR(fuse_seq.begin());
  const gpu::Buffer& vertices = current.vertices(tracking_level);
  const gpu::Buffer& normals = current.normals(tracking_level);
  fuse_seq.copy(vertices, model.vertices, vertices.size(), "first_frame_reference");
  fuse_seq.copy(normals, model.normals, normals.size(), "first_frame_reference");
  reference.record_maps_from(fuse_seq, model.vertices, model.normals, tracking_level);
  auto t = fuse_seq.submit_and_wait();
  if (!t) return t.error();
  timings.kernels.insert(timings.kernels.end(), t->begin(), t->end());
  timings.raycast_ms += ms_since(t0);
  reference_is_frame = true;
  return {};
}

std::size_t Reconstructor::Impl::valid_depth_pixels(const DepthView& depth) const {
  std::size_t n = 0;
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u) n += valid_depth(depth.metres(u, v)) ? 1 : 0;
  return n;
}

// The frame's mean depth-noise variance (m^2, DepthNoiseModel::mean_variance), kept for the
// depth image it was computed for.
double Reconstructor::Impl::noise_variance(const DepthView& depth) const {
  if (noise_variance_of != nullptr && noise_variance_of == depth.data) return noise_variance_value;
  noise_variance_value = config.icp.depth_noise.mean_variance(depth, config.preprocess.min_depth,
                                                              config.preprocess.max_depth);
  noise_variance_of = depth.data;
  return noise_variance_value;
}

// The reliability thresholds for this frame: the residual test widened to its depth noise as far
// as this scan's aligned frames show that noise, the pairing tests lowered to what they pair.
IcpReliabilityThresholds Reconstructor::Impl::reliability(const DepthView& depth) const {
  const double noise = noise_variance(depth);
  const IcpReliabilityThresholds& fixed = config.icp.reliability;
  IcpReliabilityThresholds t = fixed.widened_to_noise(noise);
  t.max_residual_per_weight =
      pairing.residual_limit(fixed.max_residual_per_weight, t.max_residual_per_weight, noise);
  pairing.apply(t.min_inlier_fraction, t.min_pixel_fraction);
  return t;
}

// The median of the frame's valid depths (m), from every 7th pixel; 0 when none is valid. Kept
// for the incoming frame (track_and_fuse forgets it), whose alignment and reference both ask.
double Reconstructor::Impl::median_depth(const DepthView& depth) {
  if (median_depth_of != nullptr && median_depth_of == depth.data) return median_depth_value;
  std::vector<double> z;
  const auto pixels = static_cast<std::size_t>(depth.width) * depth.height;
  const auto width = static_cast<std::size_t>(depth.width);
  for (std::size_t i = 0; i < pixels; i += 7) {  // a sample is enough for a median
    const double d = depth.metres(static_cast<int>(i % width), static_cast<int>(i / width));
    if (valid_depth(d)) z.push_back(d);
  }
  median_depth_value = 0;
  if (!z.empty()) {
    std::nth_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(z.size() / 2), z.end());
    median_depth_value = z[z.size() / 2];
  }
  median_depth_of = depth.data;
  return median_depth_value;
}

// How far a motion moves the image at the tracking level (pixels): `rotation` (rad) and
// `translation` (m) seen at depth z (m).
double Reconstructor::Impl::tracking_image_motion(double rotation, double translation,
                                                  double z) const {
  const double f =
      std::ldexp(std::max(config.intrinsics.fx, config.intrinsics.fy), -tracking_level);
  return f * (rotation + translation / z);
}

// The coarsest pyramid level ICP needs from an inertial seed (ReconstructorConfig::
// imu.seed_reach_pixels): the finest level at which 3 sigma of the seed's image motion, at
// the frame's median depth, is within the reach.
int Reconstructor::Impl::seed_start_level(const MotionPrediction& prediction,
                                          const DepthView& depth) {
  const int coarsest = config.preprocess.levels - 1 - tracking_level;  // ICP's levels
  const double reach = config.imu.seed_reach_pixels;
  const double z = median_depth(depth);
  if (z <= 0) return coarsest;
  const double motion =
      3 * tracking_image_motion(prediction.rotation_sigma, prediction.translation_sigma, z);
  int level = 0;
  while (level < coarsest && motion > reach * std::ldexp(1.0, level)) ++level;
  return level;
}

// ICP of the current frame against the reference from a seed; `settling`: the budget and
// convergence thresholds of a frame that must first settle onto the model (lost or
// recovering).
Result<IcpResult> Reconstructor::Impl::align(const DepthView& depth,
                                             const Eigen::Isometry3d& T_world_seed,
                                             const MotionPrediction& prediction, bool settling,
                                             FrameTimings& timings) {
  const auto t0 = Clock::now();
  IcpConfig icp = config.icp;
  // Without the IMU only a lost frame is placed partly (recovery.partial_without_imu): the held
  // directions keep the seed: the frame before moved on by the last tracked motion.
  const bool lost_without_imu = !navigator && config.recovery.partial_without_imu &&
                                machine.status() == TrackingStatus::kLost;
  icp.keep_seed_in_degenerate_directions =
      (config.imu.partial_icp && prediction.rotation_from_imu &&
       prediction.translation_predicted) ||
      lost_without_imu;
  if (lost_without_imu) icp.partial_min_fraction = config.tracking.pairing_floor;
  icp.reliability = reliability(depth);
  // The prediction measures the motion only while tracking: a lost or recovering frame's seed
  // carries the whole drift of dead reckoning, not one frame's prediction error.
  const bool on_prediction =
      prediction.rotation_from_imu && prediction.translation_predicted && !settling;
  // The seed gate also needs a velocity settled by the accelerometer: one from one or two
  // tracked pairs carries their error into the seed.
  icp.seed_gate = config.imu.seed_gate && icp.keep_seed_in_degenerate_directions && on_prediction &&
                  prediction.translation_inertial;
  icp.seed_prior = config.imu.prior && on_prediction;
  if (on_prediction) {  // the gate runs only on a prediction too
    icp.seed_sigma_rotation = prediction.rotation_sigma;
    icp.seed_sigma_translation = prediction.translation_sigma;
    // A translation held from the tracked velocity is a guess, not a measurement: the prior
    // then says only that the device moved no faster than a hand-held one can.
    if (!prediction.translation_inertial && !icp.seed_gate)
      icp.seed_sigma_translation =
          std::max(prediction.translation_sigma, config.inertial.max_speed * frame_interval);
    // The agreement test and the prior take the sigmas as off as this scan shows them to be.
    if (!icp.seed_gate) {
      icp.seed_sigma_rotation *= prediction_calibration.scale();
      icp.seed_sigma_translation *= prediction_calibration.scale();
    }
    if (seed_gate_holding) icp.seed_gate_sigmas = icp.seed_gate_hold_sigmas;
  } else if (prediction.rotation_from_imu && !settling) {
    // The first tracked frames: the gyro's rotation and no predicted translation yet. The
    // agreement test weighs the rotation, the translation bounded by a hand-held speed only, so
    // that a converged alignment the gyro confirms is not lost to the pairing tests alone.
    icp.seed_sigma_rotation = prediction.rotation_sigma * prediction_calibration.scale();
    icp.seed_sigma_translation = config.inertial.max_speed * frame_interval;
  }
  // Pixels sharing one depth error at ICP's level 0: the bilateral window, which preprocessing
  // applies at the tracking level.
  if (icp.seed_sigma_rotation > 0) {
    const int window = 2 * bilateral_radius_at_level(config.preprocess, tracking_level) + 1;
    icp.correlated_pixels = std::max(1, window * window);
  }
  // With the gyro's rotation but no predicted translation (the first tracked frames), the seed
  // is still within the finest level's reach while tracking (bench/README.md: room and fast
  // scans, 2 iterations per frame).
  if (prediction.rotation_from_imu && !settling && config.imu.seed_reach_pixels > 0) {
    const int start = on_prediction ? seed_start_level(prediction, depth) : 0;
    std::fill(icp.iterations_per_level.begin() + start + 1, icp.iterations_per_level.end(), 0);
  }
  // The budget and convergence thresholds of a frame that must settle onto the model.
  const auto settling_budget = [&](IcpConfig c) {
    c.max_total_iterations = std::max(c.max_total_iterations, config.recovery.icp_iterations);
    c.converged_rotation = std::max(c.converged_rotation, config.recovery.converged_rotation);
    c.converged_translation =
        std::max(c.converged_translation, config.recovery.converged_translation);
    return c;
  };
  if (settling) icp = settling_budget(icp);
  // The photometric term where the frame and the reference both have colour, while tracking: a
  // lost or recovering frame's seed may lie beyond the few pixels over which the colour's
  // linearization holds.
  gpu::PhotometricMaps colors;
  if (frame_has_color && reference_has_color && !settling) {
    colors.current = &color;
    colors.current_width = config.intrinsics.width;
    colors.reference = &model.colors;
    colors.config = icp.photometric;
    colors.sigma = &photometric_sigma;
  }
  gpu::GpuNormalEquationSource source(icp_kernels, icp_seq, current, reference, &timings.kernels,
                                      tracking_level, colors);
  const Eigen::Isometry3d T_ref_seed = T_world_reference.inverse() * T_world_seed;
  auto result = run_icp(source, icp, T_ref_seed);
  // A tracked frame that the per-frame budget left unconverged and unreliable is given the
  // settling budget from the same seed before it counts as lost: the tests judge an alignment,
  // not an unfinished one.
  const IcpConfig retry = settling_budget(icp);
  if (result && !settling && !result->reliable() && !result->partial() &&
      !result->quality.converged && retry.max_total_iterations > icp.max_total_iterations) {
    const int spent = result->quality.iterations;
    result = run_icp(source, retry, T_ref_seed);
    if (result) result->quality.iterations += spent;
  }
  // The depth decides: an alignment the colour pulled off what the depth supports is run again
  // on the depth alone, from the same seed and with the settling budget.
  if (result && !result->reliable() && !result->partial() && colors.current != nullptr &&
      colors.config.weight > 0) {
    const int spent = result->quality.iterations;
    gpu::GpuNormalEquationSource depth_only(icp_kernels, icp_seq, current, reference,
                                            &timings.kernels, tracking_level);
    result = run_icp(depth_only, retry, T_ref_seed);
    if (result) result->quality.iterations += spent;
  }
  timings.icp_ms += ms_since(t0);
  return result;
}

Status Reconstructor::Impl::load_frame(const DepthView& depth, FrameTimings& timings) {
  return preprocess(depth, nullptr, timings);
}

Status Reconstructor::Impl::set_reference(const Eigen::Isometry3d& T_world_camera,
                                          FrameTimings& timings) {
  auto updated = fuse_and_update_reference(T_world_camera, false, false, timings);
  return updated ? Status{} : Status{updated.error()};
}

Result<ModelAligner::Placement> Reconstructor::Impl::place(const DepthView& depth,
                                                           const Eigen::Isometry3d& T_world_seed,
                                                           FrameTimings& timings) {
  IMUFUSION_RETURN_IF_ERROR(set_reference(T_world_seed, timings));
  auto icp = align(depth, T_world_seed, MotionPrediction{}, true, timings);
  if (!icp) return icp.error();
  return Placement{*icp, T_world_reference * icp->T_ref_cur};
}

Result<ModelAligner::FramePoints> Reconstructor::Impl::frame_points(int level) {
  const Intrinsics& k = current.intrinsics(level);
  auto map = download_map(current.vertices(level), k.width, k.height);
  if (!map) return map.error();
  auto normal_map = download_map(current.normals(level), k.width, k.height);
  if (!normal_map) return normal_map.error();
  FramePoints out;
  for (std::size_t i = 0; i < map->data.size(); ++i) {
    const Eigen::Vector4f& v = map->data[i];
    if (v.w() <= 0.5f) continue;
    out.points.push_back(v.head<3>().cast<double>());
    // A pixel without a normal (an edge of the depth) keeps a zero one.
    const Eigen::Vector3d n = normal_map->data[i].head<3>().cast<double>();
    out.normals.push_back(n.allFinite() && n.norm() > 0.5 ? n.normalized()
                                                          : Eigen::Vector3d::Zero());
  }
  return out;
}

}  // namespace imufusion
