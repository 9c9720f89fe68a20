// GPU ICP kernels against their CPU references, and the GPU tracker recovering known motions.
// Tolerances: association rows are compared where both sides accept the pair (rows of a float
// shader vs a double reference: |a - a_ref| <= 1e-4 * (1 + |a_ref|), |b - b_ref| <= 1e-5 m,
// |w - w_ref| <= 1e-4); acceptance may differ on at most 0.2% of pixels (projections landing on
// a pixel boundary, distances at the threshold). The reduction is compared with the reference
// reduction of the GPU's own rows: relative 1e-4 on every sum, exact counts.

#include "imufusion/icp.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>

#include "../support/synth_config.hpp"
#include "gpu/icp_kernels.hpp"
#include "gpu/preprocessor.hpp"
#include "gpu/rgba.hpp"
#include "gpu_test_env.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/synth.hpp"
#include "imufusion_layouts.h"
#include "reference/icp_reference.hpp"
#include "vk/command_sequence.hpp"

namespace imufusion {
namespace {

using test::GpuTest;

Eigen::Isometry3d motion(double angle_deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

double rotation_deg(const Eigen::Isometry3d& T) {
  return Eigen::AngleAxisd(T.linear()).angle() * 180.0 / M_PI;
}

struct Frames {
  Intrinsics k;
  DepthImage reference, current;
  Eigen::Isometry3d T_ref_cur;
};

Frames room_frames(int width, int height, const Eigen::Isometry3d& T_ref_cur,
                   bool noisy_reference) {
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 2);
  const Eigen::Isometry3d T_world_ref =
      synth::CameraMotion(synth::SceneKind::kRoom, 5).pose_at(2.0);
  Frames f;
  f.k = synth::default_intrinsics(width, height);
  synth::SensorModel noisy;
  synth::SensorModel clean;
  clean.depth_noise = false;
  f.reference = synth::render_depth(scene, T_world_ref, f.k, noisy_reference ? noisy : clean, 11);
  f.current = synth::render_depth(scene, T_world_ref * T_ref_cur, f.k, noisy, 12);
  f.T_ref_cur = T_ref_cur;
  return f;
}

// The GPU's reduced normal equations against the reference's, to float accumulation (1e-4).
void expect_equations_match(const NormalEquations& gpu, const NormalEquations& want) {
  EXPECT_EQ(gpu.inliers, want.inliers);
  EXPECT_EQ(gpu.valid_pixels, want.valid_pixels);
  EXPECT_GT(want.valid_pixels, want.inliers);
  auto near = [](double a, double b) { return std::abs(a - b) <= 1e-4 * (std::abs(b) + 1e-6); };
  EXPECT_GT(want.valid_information, want.inlier_information);
  EXPECT_GT(want.inlier_information, 0.0);
  EXPECT_TRUE(near(gpu.valid_information, want.valid_information))
      << gpu.valid_information << " vs " << want.valid_information;
  EXPECT_TRUE(near(gpu.inlier_information, want.inlier_information))
      << gpu.inlier_information << " vs " << want.inlier_information;
  EXPECT_EQ(gpu.uncovered_pixels, want.uncovered_pixels);
  EXPECT_TRUE(near(gpu.uncovered_information, want.uncovered_information))
      << gpu.uncovered_information << " vs " << want.uncovered_information;
  for (int i = 0; i < 6; ++i) {
    EXPECT_TRUE(near(gpu.Atb(i), want.Atb(i))) << gpu.Atb(i) << " vs " << want.Atb(i);
    for (int j = 0; j < 6; ++j) EXPECT_TRUE(near(gpu.AtA(i, j), want.AtA(i, j))) << i << "," << j;
  }
  EXPECT_TRUE(near(gpu.btb, want.btb));
  EXPECT_TRUE(near(gpu.weight_sum, want.weight_sum));
}

// GetParam(): the reduction adds across subgroups (where the device can; skipped elsewhere) or
// through the shared-memory tree.
class IcpReductionTest : public GpuTest, public ::testing::WithParamInterface<bool> {};

TEST_P(IcpReductionTest, AssociationAndReductionMatchTheReference) {
  if (GetParam() && !context_->info().subgroup_arithmetic)
    GTEST_SKIP() << "the device has no subgroup arithmetic";
  const Frames f = room_frames(97, 61, motion(1.5, {0.2, 1, 0.1}, {0.02, 0.01, -0.03}), true);
  const PreprocessConfig config;
  auto ref = gpu::Preprocessor::create(context_, config, f.k);
  auto cur = gpu::Preprocessor::create(context_, config, f.k);
  ASSERT_TRUE(ref.ok() && cur.ok());
  auto seq = gpu::CommandSequence::create(context_, ref->dispatch_count());
  ASSERT_TRUE(seq.ok());
  for (auto [pre, depth] : {std::pair{&*ref, &f.reference}, std::pair{&*cur, &f.current}}) {
    ASSERT_TRUE(pre->upload(*depth).ok());
    ASSERT_TRUE(seq->begin().ok());
    pre->record(*seq);
    ASSERT_TRUE(seq->submit_and_wait().ok());
  }
  auto ref_maps = ref->download();
  auto cur_maps = cur->download();
  ASSERT_TRUE(ref_maps.ok() && cur_maps.ok());

  const DepthNoiseModel noise;
  const NormalGate gate;  // the default widens the normal test on the far pixels
  auto kernels = gpu::IcpKernels::create(context_, 97 * 61, 16, 16, noise, gate, GetParam());
  ASSERT_TRUE(kernels.ok()) << kernels.error().describe();
  auto icp_seq = gpu::CommandSequence::create(context_, gpu::IcpKernels::kDispatches);
  ASSERT_TRUE(icp_seq.ok());
  const Eigen::Isometry3d T = motion(1.0, {0.2, 1, 0.1}, {0.015, 0.01, -0.02});  // near the truth
  const float max_distance = 0.1f;
  const float min_cos = static_cast<float>(std::cos(20.0 * M_PI / 180.0));
  for (int level = 0; level < config.levels; ++level) {
    const auto l = static_cast<std::size_t>(level);
    const Intrinsics kl = f.k.at_level(level);
    ASSERT_TRUE(icp_seq->begin().ok());
    kernels->record(*icp_seq, {&cur->vertices(level), &cur->normals(level), kl.width, kl.height},
                    {&ref->vertices(level), &ref->normals(level), kl.width, kl.height}, kl, T,
                    max_distance, min_cos, level);
    ASSERT_TRUE(icp_seq->submit_and_wait().ok());
    auto gpu_eq = kernels->read_equations();
    ASSERT_TRUE(gpu_eq.ok());
    auto raw_rows = kernels->rows().download_as<float>(static_cast<std::size_t>(kl.width) *
                                                       kl.height * ICP_ROW_FLOATS);
    ASSERT_TRUE(raw_rows.ok());

    const auto expected =
        reference::icp_associate(cur_maps->vertices[l], cur_maps->normals[l], ref_maps->vertices[l],
                                 ref_maps->normals[l], kl, T, max_distance, min_cos, noise, gate);
    std::vector<reference::IcpRow> gpu_rows(expected.size());
    int accept_mismatch = 0, value_mismatch = 0, accepted = 0, cover_mismatch = 0, uncovered = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      const float* r = &(*raw_rows)[i * ICP_ROW_FLOATS];
      reference::IcpRow& g = gpu_rows[i];
      for (int j = 0; j < 6; ++j) g.a(j) = r[j];
      g.b = r[6];
      g.w = r[7];
      g.valid = r[7] != 0.0f;
      g.covered = g.valid && r[7] != -2.0f;
      g.z = cur_maps->vertices[l].data[i].z();
      EXPECT_EQ(g.valid, expected[i].valid) << "pixel " << i;
      cover_mismatch += g.covered != expected[i].covered ? 1 : 0;
      uncovered += expected[i].valid && !expected[i].covered ? 1 : 0;
      const bool gpu_accepts = g.w > 0, ref_accepts = expected[i].w > 0;
      accepted += ref_accepts ? 1 : 0;
      if (gpu_accepts != ref_accepts) {
        ++accept_mismatch;
        continue;
      }
      if (!gpu_accepts) continue;
      const bool close = ((g.a - expected[i].a).cwiseAbs().array() <=
                          1e-4 * (1 + expected[i].a.cwiseAbs().array()))
                             .all() &&
                         std::abs(g.b - expected[i].b) <= 1e-5 &&
                         std::abs(g.w - expected[i].w) <= 1e-4;
      value_mismatch += close ? 0 : 1;
    }
    EXPECT_GT(accepted, 50) << "level " << level << " must have correspondences";
    EXPECT_LE(accept_mismatch, 0.002 * double(expected.size()) + 1) << "level " << level;
    // The motion moves the border pixels out of the reference image: some are not covered, and
    // the GPU marks the same ones (to rounding at the border).
    EXPECT_GT(uncovered, 0) << "level " << level;
    EXPECT_LE(cover_mismatch, 0.002 * double(expected.size()) + 1) << "level " << level;
    EXPECT_EQ(value_mismatch, 0) << "level " << level;

    const NormalEquations want = reference::icp_reduce(gpu_rows, noise);
    expect_equations_match(*gpu_eq, want);
  }
}

INSTANTIATE_TEST_SUITE_P(Variants, IcpReductionTest, ::testing::Values(true, false),
                         [](const ::testing::TestParamInfo<bool>& param) {
                           return param.param ? "Subgroups" : "SharedMemoryTree";
                         });

TEST_F(GpuTest, ReductionIsDeterministic) {
  const Frames f = room_frames(97, 61, motion(1.0, {0, 1, 0}, {0.01, 0, 0}), true);
  auto tracker_a = IcpTracker::create(IcpConfig{}, PreprocessConfig{}, f.k);
  ASSERT_TRUE(tracker_a.ok());
  ASSERT_TRUE(tracker_a->set_reference(f.reference).ok());
  auto first = tracker_a->track(f.current, Eigen::Isometry3d::Identity());
  auto second = tracker_a->track(f.current, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(first.ok() && second.ok());
  EXPECT_EQ(first->T_ref_cur.matrix(), second->T_ref_cur.matrix());
  EXPECT_EQ(first->quality.residual, second->quality.residual);
}

class IcpTrackerTest : public GpuTest, public ::testing::WithParamInterface<bool> {};

// Reference: the previous noisy frame (frame-to-frame, GetParam() = true) or a noiseless
// rendering at the reference pose (as a model raycast provides, false).
TEST_P(IcpTrackerTest, RecoversAKnownMotion) {
  const Frames f =
      room_frames(320, 240, motion(2.0, {0.3, 1, -0.2}, {0.03, -0.02, 0.04}), GetParam());
  DeviceOptions device;
  device.validation = true;
  auto tracker = IcpTracker::create(IcpConfig{}, PreprocessConfig{}, f.k, device);
  ASSERT_TRUE(tracker.ok()) << tracker.error().describe();
  ASSERT_TRUE(tracker->set_reference(f.reference).ok());
  std::vector<KernelTiming> timings;
  auto result = tracker->track(f.current, Eigen::Isometry3d::Identity(), &timings);
  ASSERT_TRUE(result.ok()) << result.error().describe();
  const Eigen::Isometry3d error = f.T_ref_cur.inverse() * result->T_ref_cur;
  EXPECT_LT(error.translation().norm(), 0.002) << error.translation().transpose();
  EXPECT_LT(rotation_deg(error), 0.1);
  EXPECT_TRUE(result->reliable()) << result->reason;
  EXPECT_FALSE(timings.empty());
  EXPECT_EQ(tracker->validation_error_count(), 0u);
}

INSTANTIATE_TEST_SUITE_P(References, IcpTrackerTest, ::testing::Values(true, false));

// Frame-to-model: the reference maps are a raycast of a volume fused from frames around the
// reference pose (ground-truth poses, Reconstructor::fuse_with_pose), as the scanner tracks
// against its model.
TEST_F(GpuTest, FrameToModelRecoversAKnownMotion) {
  const Intrinsics k = synth::default_intrinsics(320, 240);
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 2);
  const synth::CameraMotion path(synth::SceneKind::kRoom, 5);
  ReconstructorConfig config;
  config.intrinsics = k;
  config.volume.block_capacity = 1u << 14;
  config.volume.hash_slots = 1u << 15;
  config.imu.enabled = false;
  config.device.validation = true;
  auto fusion = Reconstructor::create(config);
  ASSERT_TRUE(fusion.ok()) << fusion.error().describe();
  for (int f = 0; f < 6; ++f) {
    const Eigen::Isometry3d T = path.pose_at(1.8 + 0.08 * f);
    ASSERT_TRUE(fusion
                    ->fuse_with_pose(
                        0.08 * f,
                        synth::render_depth(scene, T, k, {}, 40 + static_cast<std::uint64_t>(f)),
                        nullptr, T)
                    .ok());
  }
  const Eigen::Isometry3d T_world_ref = path.pose_at(2.0);
  auto model = fusion->raycast(T_world_ref);
  ASSERT_TRUE(model.ok()) << model.error().describe();
  EXPECT_EQ(fusion->validation_error_count(), 0u);

  const Eigen::Isometry3d T_ref_cur = motion(1.5, {0.3, 1, -0.2}, {0.02, -0.015, 0.03});
  const DepthImage current = synth::render_depth(scene, T_world_ref * T_ref_cur, k, {}, 99);
  auto tracker = IcpTracker::create(IcpConfig{}, PreprocessConfig{}, k, config.device);
  ASSERT_TRUE(tracker.ok());
  ASSERT_TRUE(tracker->set_reference_maps(model->vertices, model->normals).ok());
  auto result = tracker->track(current, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok()) << result.error().describe();
  const Eigen::Isometry3d error = T_ref_cur.inverse() * result->T_ref_cur;
  EXPECT_LT(error.translation().norm(), 0.002) << error.translation().transpose();
  EXPECT_LT(rotation_deg(error), 0.1);
  EXPECT_TRUE(result->reliable()) << result->reason;
  EXPECT_EQ(tracker->validation_error_count(), 0u);

  Vec4Image wrong_size;
  wrong_size.width = 10;
  wrong_size.height = 10;
  wrong_size.data.assign(100, Eigen::Vector4f::Zero());
  EXPECT_FALSE(tracker->set_reference_maps(wrong_size, wrong_size).ok());
}

TEST_F(GpuTest, AFlatWallIsFlaggedUnreliable) {
  synth::Scene wall;
  synth::Plane plane;
  plane.normal = Eigen::Vector3d(0, 0, 1);
  plane.offset = 1.0;
  wall.planes.push_back(plane);
  const Intrinsics k = synth::default_intrinsics(160, 120);
  const DepthImage ref = synth::render_depth(wall, Eigen::Isometry3d::Identity(), k, {}, 1);
  const DepthImage cur =
      synth::render_depth(wall, motion(0.5, {0, 1, 0}, {0.03, 0.01, 0}), k, {}, 2);
  auto tracker = IcpTracker::create(IcpConfig{}, PreprocessConfig{}, k);
  ASSERT_TRUE(tracker.ok());
  ASSERT_TRUE(tracker->set_reference(ref).ok());
  auto result = tracker->track(cur, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok());
  EXPECT_GT(result->quality.condition, 1e3);
  EXPECT_FALSE(result->reliable());
}

// The photometric term's rows (icp_photometric): against a checkered wall, whose depth leaves the
// two translations along it and the rotation about its normal free, ICP with the colour finds the
// camera's motion in all six directions; on depth alone the motion along the wall is not seen.
TEST_F(GpuTest, TheColourFindsTheMotionAlongACheckeredWall) {
  const synth::Scene scene = test::checkered_wall();
  const Intrinsics k = synth::default_intrinsics(160, 120);
  const Eigen::Isometry3d moved = motion(0.4, {0, 0, 1}, {0.012, -0.008, 0});
  const PreprocessConfig config;
  auto ref = gpu::Preprocessor::create(context_, config, k);
  auto cur = gpu::Preprocessor::create(context_, config, k);
  ASSERT_TRUE(ref.ok() && cur.ok());
  auto seq = gpu::CommandSequence::create(context_, ref->dispatch_count());
  ASSERT_TRUE(seq.ok());
  std::vector<gpu::Buffer> colors;
  std::vector<std::uint32_t> scratch;
  for (auto [pre, pose] :
       {std::pair{&*ref, Eigen::Isometry3d::Identity()}, std::pair{&*cur, moved}}) {
    ASSERT_TRUE(pre->upload(synth::render_depth(scene, pose, k, {}, 5)).ok());
    ASSERT_TRUE(seq->begin().ok());
    pre->record(*seq);
    ASSERT_TRUE(seq->submit_and_wait().ok());
    auto buffer = gpu::Buffer::create(context_, static_cast<std::size_t>(k.width) * k.height * 4);
    ASSERT_TRUE(buffer.ok());
    ASSERT_TRUE(gpu::upload_rgba(synth::render_color(scene, pose, k), *buffer, scratch).ok());
    colors.push_back(std::move(*buffer));
  }
  auto kernels = gpu::IcpKernels::create(context_, static_cast<std::size_t>(k.width) * k.height, 16,
                                         16, DepthNoiseModel{});
  ASSERT_TRUE(kernels.ok()) << kernels.error().describe();
  auto icp_seq = gpu::CommandSequence::create(context_, gpu::IcpKernels::kPhotometricDispatches);
  ASSERT_TRUE(icp_seq.ok());
  IcpConfig icp;
  icp.iterations_per_level = {20, 0, 0};
  icp.max_total_iterations = 20;
  // Every pixel, every other pixel in x and y, and no colour.
  for (const auto& [weight, step] : {std::pair{1.0, 1}, std::pair{1.0, 2}, std::pair{0.0, 1}}) {
    SCOPED_TRACE("weight " + std::to_string(weight) + ", pixel step " + std::to_string(step));
    double sigma = 0;
    gpu::PhotometricMaps maps{&colors[1], k.width, &colors[0], icp.photometric, &sigma};
    maps.config.weight = weight;
    maps.config.pixel_step = step;
    gpu::GpuNormalEquationSource source(*kernels, *icp_seq, *cur, *ref, nullptr, 0, maps);
    auto result = run_icp(source, icp, Eigen::Isometry3d::Identity());
    ASSERT_TRUE(result.ok()) << result.error().describe();
    const double error = (result->T_ref_cur.translation() - moved.translation()).norm();
    if (weight > 0) {
      EXPECT_LT(error, 0.002);
      EXPECT_LT(rotation_deg(result->T_ref_cur * moved.inverse()), 0.1);
      EXPECT_GT(sigma, 0.0);  // the Huber scale of the next evaluation
    } else {
      EXPECT_GT(error, 0.007);  // the motion along the wall is not seen
    }
  }
}

TEST_F(GpuTest, ALargeMotionFromTheWrongStartIsFlaggedOrFails) {
  const Frames f = room_frames(160, 120, motion(25.0, {0, 1, 0}, {0.4, 0, 0.2}), true);
  auto tracker = IcpTracker::create(IcpConfig{}, PreprocessConfig{}, f.k);
  ASSERT_TRUE(tracker.ok());
  ASSERT_TRUE(tracker->set_reference(f.reference).ok());
  auto result = tracker->track(f.current, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok());
  const Eigen::Isometry3d error = f.T_ref_cur.inverse() * result->T_ref_cur;
  const bool landed = error.translation().norm() < 0.01 && rotation_deg(error) < 1.0;
  EXPECT_TRUE(landed || !result->reliable())
      << "a wrong pose was reported reliable: error " << error.translation().norm() << " m, "
      << rotation_deg(error) << " deg";
  EXPECT_TRUE(result->T_ref_cur.matrix().allFinite());
}

TEST_F(GpuTest, TrackBeforeReferenceAndNanStartAreHandled) {
  const Frames f = room_frames(97, 61, Eigen::Isometry3d::Identity(), true);
  auto tracker = IcpTracker::create(IcpConfig{}, PreprocessConfig{}, f.k);
  ASSERT_TRUE(tracker.ok());
  EXPECT_FALSE(tracker->track(f.current, Eigen::Isometry3d::Identity()).ok());
  ASSERT_TRUE(tracker->set_reference(f.reference).ok());
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan(1, 1) = std::nan("");
  auto result = tracker->track(f.current, nan);
  ASSERT_TRUE(result.ok());
  EXPECT_FALSE(result->reliable());
  EXPECT_TRUE(result->T_ref_cur.matrix().allFinite());
}

}  // namespace
}  // namespace imufusion
