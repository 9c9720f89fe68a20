// Loss recovery's backward retrack: the lost frames kept before a recovery, placed by ICP from
// the recovering frame back, while each is placed. With the gyroscope a frame whose alignment
// fixes the position (a view leaving a wall) counts as placed, as in the relocalization search.
// The alignments are a scripted stand-in for the GPU's.

#include "scan/loss_recovery.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <vector>

#include "mesh_test_fixtures.hpp"

namespace imufusion {
namespace {

// Each place() call (newest lost frame first) answers with the next quality in `answers`; none
// left: no fit.
class ScriptedAligner : public ModelAligner {
 public:
  std::vector<IcpQuality> answers;
  int placed = 0;  // place() calls

  Status load_frame(const DepthView&, FrameTimings&) override { return {}; }
  Status set_reference(const Eigen::Isometry3d&, FrameTimings&) override { return {}; }
  Result<Placement> place(const DepthView&, const Eigen::Isometry3d& seed, FrameTimings&) override {
    Placement p;
    p.T_world_camera = seed;
    if (static_cast<std::size_t>(placed) < answers.size()) {
      p.icp.quality = answers[static_cast<std::size_t>(placed)];
      IcpReliabilityThresholds t;
      p.icp.verdict =
          judge_icp(p.icp.quality, t, nullptr) ? IcpVerdict::kReliable : IcpVerdict::kUnreliable;
    }
    ++placed;
    return p;
  }
  IcpReliabilityThresholds reliability(const DepthView&) const override { return {}; }
  Result<FramePoints> frame_points(int) override { return FramePoints{}; }
  Result<HostVolume> model_snapshot() const override { return HostVolume{}; }
};

// A converged alignment that passes every test but the condition number (kappa 1e4), with its
// translation's kappa `translation_condition`.
IcpQuality leaving_the_wall(double translation_condition) {
  IcpQuality q;
  q.iterations = 5;
  q.converged = true;
  q.inliers = 5000;
  q.inlier_fraction = q.pixel_fraction = 0.8;
  q.residual_per_weight = 1e-6;
  q.condition = 1e4;
  q.translation_condition = translation_condition;
  return q;
}

// Frame 0 tracked, frames 1-5 lost (dead reckoning, their depth kept), frame 6 relocalized
// (tracking again at once); the frames the retrack placed.
std::size_t retracked_frames(const ReconstructorConfig& config, bool with_imu,
                             ScriptedAligner& model) {
  LossRecovery recovery(config);
  auto navigator = InertialNavigator::create(config.inertial);
  EXPECT_TRUE(navigator.ok());
  InertialNavigator* imu = with_imu && navigator.ok() ? &*navigator : nullptr;
  std::vector<std::uint16_t> pixels(16, 5000);
  const DepthView depth = DepthView::uint16(pixels.data(), 4, 4, 5000);
  Trajectory trajectory;
  FrameTimings timings;
  std::size_t placed = 0;
  for (std::size_t i = 0; i <= 6; ++i) {
    LossRecovery::Frame f;
    f.index = i;
    f.timestamp = static_cast<double>(i) / 30;
    f.T_world_seed.translation() = Eigen::Vector3d(0.01 * static_cast<double>(i), 0, 0);
    f.T_world_estimate = f.T_world_camera = f.T_world_seed;
    f.was_lost = i >= 2;
    if (i == 0) {
      f.decision = {TrackingStatus::kTracking, PoseSource::kIcp, true, 0, false};
    } else if (i < 6) {
      f.decision = {TrackingStatus::kLost, PoseSource::kDeadReckoning, false, 0, false};
    } else {
      f.decision = {TrackingStatus::kTracking, PoseSource::kIcp, true, 1, true};
      f.T_world_camera.translation().y() += 0.05;  // dead reckoning's drift, corrected
    }
    trajectory.push_back({f.timestamp, f.T_world_camera});
    auto out = recovery.on_frame(f, depth, imu, trajectory, model, timings);
    EXPECT_TRUE(out.ok());
    if (out.ok()) placed += *out;
  }
  return placed;
}

TEST(LossRecoveryRetrack, WithTheGyroAFrameWhosePositionIsFixedIsPlaced) {
  // Frame 5 fixes its position (translation kappa 20, within relocalization.
  // max_translation_condition, 100), frame 4 slides along the wall (150): one frame placed.
  ReconstructorConfig config;
  ASSERT_NEAR(config.relocalization.max_translation_condition, 100, 1e-12);
  ScriptedAligner model;
  model.answers = {leaving_the_wall(20), leaving_the_wall(150)};
  EXPECT_EQ(retracked_frames(config, /*with_imu=*/true, model), 1u);
  EXPECT_EQ(model.placed, 2);
}

TEST(LossRecoveryRetrack, WithoutTheGyroOrWithTheLimitOffItIsNot) {
  ReconstructorConfig config;
  ScriptedAligner without;
  without.answers = {leaving_the_wall(20)};
  EXPECT_EQ(retracked_frames(config, /*with_imu=*/false, without), 0u);
  config.relocalization.max_translation_condition = 0;
  ScriptedAligner off;
  off.answers = {leaving_the_wall(20)};
  EXPECT_EQ(retracked_frames(config, /*with_imu=*/true, off), 0u);
}

}  // namespace
}  // namespace imufusion
