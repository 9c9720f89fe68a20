// Host ICP with no GPU: the 6x6 step, the increment, the quality decision, and run_icp over the
// CPU reference kernels on synthetic frames of the room.

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <vector>

#include "imufusion/icp.hpp"
#include "imufusion/synth.hpp"
#include "reference/icp_reference.hpp"
#include "reference/preprocess_reference.hpp"

namespace imufusion {
namespace {

double rotation_deg(const Eigen::Isometry3d& T) {
  return Eigen::AngleAxisd(T.linear()).angle() * 180.0 / M_PI;
}

Eigen::Isometry3d small_motion(double angle_deg, const Eigen::Vector3d& axis,
                               const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

/// The plane z = 1 alone: in world = camera coordinates of the identity pose, a wall 1 m ahead.
synth::Scene flat_wall() {
  synth::Scene wall;
  synth::Plane plane;
  plane.normal = Eigen::Vector3d(0, 0, 1);
  plane.offset = 1.0;
  wall.planes.push_back(plane);
  return wall;
}

struct Pair {
  PreprocessedFrame reference, current;
  Intrinsics k;
  Eigen::Isometry3d T_ref_cur;
};

// Two views of a scene: the reference at `T_world_ref`, the current one moved by `motion`.
Pair render_pair(const synth::Scene& scene, const Eigen::Isometry3d& T_world_ref,
                 const Eigen::Isometry3d& motion, bool noise, int width = 160, int height = 120) {
  Pair pair;
  pair.k = synth::default_intrinsics(width, height);
  synth::SensorModel model;
  model.depth_noise = noise;
  const Eigen::Isometry3d T_world_cur = T_world_ref * motion;
  const PreprocessConfig config;
  pair.reference = reference::preprocess(synth::render_depth(scene, T_world_ref, pair.k, model, 1),
                                         pair.k, config);
  pair.current = reference::preprocess(synth::render_depth(scene, T_world_cur, pair.k, model, 2),
                                       pair.k, config);
  pair.T_ref_cur = motion;
  return pair;
}

Eigen::Isometry3d room_view() {
  return synth::CameraMotion(synth::SceneKind::kRoom, 3).pose_at(1.0);
}

TEST(IcpStep, SolvesAKnownLinearSystem) {
  // Rows a_i with b_i = a_i . x_true: the step must return x_true and a zero residual.
  Eigen::Matrix<double, 6, 1> x_true;
  x_true << 0.01, -0.02, 0.005, 0.03, -0.01, 0.02;
  NormalEquations eq;
  std::srand(1);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Matrix<double, 6, 1> a = Eigen::Matrix<double, 6, 1>::Random();
    const double b = a.dot(x_true);
    eq.AtA += a * a.transpose();
    eq.Atb += a * b;
    eq.btb += b * b;
    eq.inliers++;
    eq.weight_sum += 1;
  }
  const IcpStep step = solve_icp_step(eq);
  ASSERT_TRUE(step.solvable);
  EXPECT_LT((step.x - x_true).norm(), 1e-10);
  EXPECT_NEAR(step.residual, 0.0, 1e-10);
  EXPECT_GT(step.condition, 1.0);
  EXPECT_TRUE(std::isfinite(step.condition));
}

TEST(IcpStep, EmptyOrNonFiniteSystemIsNotSolvable) {
  EXPECT_FALSE(solve_icp_step(NormalEquations{}).solvable);
  NormalEquations eq;
  eq.inliers = 100;
  eq.AtA.setIdentity();
  eq.AtA(2, 2) = std::numeric_limits<double>::quiet_NaN();
  const IcpStep step = solve_icp_step(eq);
  EXPECT_FALSE(step.solvable);
  EXPECT_TRUE(step.x.allFinite());
}

TEST(IcpStep, TruncatedSolveMovesOnlyAlongWellConditionedDirections) {
  // AtA with three strong and three weak singular directions (a rotated basis, so the directions
  // are not the coordinate axes).
  const Eigen::Matrix<double, 6, 6> Q =
      Eigen::HouseholderQR<Eigen::Matrix<double, 6, 6>>(Eigen::Matrix<double, 6, 6>::Random())
          .householderQ();
  Eigen::Matrix<double, 6, 1> s;
  s << 4.0, 2.0, 1.0, 1e-5, 1e-6, 1e-7;
  NormalEquations eq;
  eq.AtA = Q * s.asDiagonal() * Q.transpose();
  Eigen::Matrix<double, 6, 1> x_true;
  x_true << 0.01, -0.02, 0.005, 0.03, -0.01, 0.02;
  eq.Atb = eq.AtA * x_true;
  eq.btb = x_true.dot(eq.AtA * x_true);
  eq.inliers = 1000;
  eq.weight_sum = 1000;
  const IcpStep full = solve_icp_step(eq);
  EXPECT_EQ(full.constrained_directions, 6);
  EXPECT_LT((full.x - x_true).norm(), 1e-6);
  const IcpStep truncated = solve_icp_step(eq, 100.0);
  ASSERT_TRUE(truncated.solvable);
  EXPECT_EQ(truncated.constrained_directions, 3);
  // The projection of x_true onto the strong directions, nothing along the weak ones.
  const Eigen::Matrix<double, 6, 3> strong = Q.leftCols<3>();
  EXPECT_LT((truncated.x - strong * strong.transpose() * x_true).norm(), 1e-9);
  EXPECT_LT((Q.rightCols<3>().transpose() * truncated.x).norm(), 1e-9);
  EXPECT_TRUE(full.fixed_translation.isIdentity());
  // A projector: symmetric, idempotent.
  const Eigen::Matrix3d P = truncated.fixed_translation;
  EXPECT_LT((P - P.transpose()).norm(), 1e-12);
  EXPECT_LT((P * P - P).norm(), 1e-9);
}

void add_row(NormalEquations& eq, const Eigen::Matrix<double, 6, 1>& a, double b) {
  eq.AtA += a * a.transpose();
  eq.Atb += a * b;
  eq.btb += b * b;
  eq.inliers++;
  eq.weight_sum += 1;
}

// Rows a . x = b of a wall's depth term (x = alpha, beta, gamma, tx, ty, tz): the normal's
// direction (tz) and the two tilts, nothing along the wall; `noise` (m) added to b alternately.
NormalEquations wall_equations(const Eigen::Matrix<double, 6, 1>& x, double noise) {
  NormalEquations eq;
  for (int i = 0; i < 300; ++i) {
    Eigen::Matrix<double, 6, 1> a = Eigen::Matrix<double, 6, 1>::Zero();
    a(0) = std::sin(0.1 * i);  // the tilts' lever arms over the wall
    a(1) = std::cos(0.13 * i);
    a(5) = 1;
    add_row(eq, a, a.dot(x) + (i % 2 == 0 ? noise : -noise));
  }
  return eq;
}

// Rows of a photometric term that constrain all six directions: gradients (intensity per unit of
// x) of random directions, `noise` (intensity) added to b alternately.
NormalEquations colour_equations(const Eigen::Matrix<double, 6, 1>& x, double noise) {
  NormalEquations eq;
  std::srand(3);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Matrix<double, 6, 1> a = 20 * Eigen::Matrix<double, 6, 1>::Random();
    add_row(eq, a, a.dot(x) + (i % 2 == 0 ? noise : -noise));
  }
  return eq;
}

TEST(IcpPhotometric, EachTermIsWeighedByItsOwnResidual) {
  Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
  NormalEquations eq = wall_equations(x, 0.002);             // 4e-6 m^2 per weight
  const NormalEquations colour = colour_equations(x, 0.05);  // 2.5e-3 per weight
  const NormalEquations depth = eq;
  add_photometric(eq, colour, 2.0);
  const double lambda = 2.0 * 4e-6 / 2.5e-3;
  EXPECT_LT((eq.photometric_AtA - lambda * colour.AtA).norm(), 1e-9 * colour.AtA.norm());
  EXPECT_LT((eq.photometric_Atb - lambda * colour.Atb).norm(), 1e-9 * colour.Atb.norm() + 1e-15);
  EXPECT_EQ(eq.photometric_pairs, colour.inliers);
  // The depth's own sums are left as they were: the residual and the pairing stay the depth's.
  EXPECT_EQ(eq.AtA, depth.AtA);
  EXPECT_EQ(eq.btb, depth.btb);
  EXPECT_EQ(eq.weight_sum, depth.weight_sum);
  // No weight, or a term without residual, adds nothing.
  NormalEquations unchanged = depth;
  add_photometric(unchanged, colour, 0.0);
  add_photometric(unchanged, NormalEquations{}, 1.0);
  EXPECT_TRUE(unchanged.photometric_AtA.isZero());
  EXPECT_EQ(unchanged.photometric_pairs, 0u);
  // A depth residual below the sensor's least noise counts as that noise.
  NormalEquations exact = wall_equations(x, 0.0);
  add_photometric(exact, colour, 1.0, 1e-6);
  EXPECT_LT((exact.photometric_AtA - 1e-6 / 2.5e-3 * colour.AtA).norm(), 1e-9 * colour.AtA.norm());
  // A colour residual below the camera's least noise counts as that noise; above it, as itself.
  NormalEquations floored = depth;
  add_photometric(floored, colour, 1.0, 0.0, 1e-2);
  EXPECT_LT((floored.photometric_AtA - 4e-6 / 1e-2 * colour.AtA).norm(), 1e-9 * colour.AtA.norm());
  NormalEquations above = depth;
  add_photometric(above, colour, 1.0, 0.0, 1e-4);
  EXPECT_LT((above.photometric_AtA - 4e-6 / 2.5e-3 * colour.AtA).norm(), 1e-9 * colour.AtA.norm());
}

TEST(IcpPhotometric, TheColourCompletesAWallOnlyInAFullSolve) {
  Eigen::Matrix<double, 6, 1> x;
  x << 0.002, -0.001, 0.004, 0.01, -0.006, 0.003;
  NormalEquations eq = wall_equations(x, 0.001);
  const IcpStep depth_only = solve_icp_step(eq, 562.3);
  EXPECT_EQ(depth_only.constrained_directions, 3);
  EXPECT_FALSE(std::isfinite(depth_only.condition) && depth_only.condition < 1e6);
  add_photometric(eq, colour_equations(x, 0.01), 1.0);
  // Without degeneracy-aware solving the colour fixes the slide along the wall.
  const IcpStep full = solve_icp_step(eq);
  ASSERT_TRUE(full.solvable);
  EXPECT_EQ(full.constrained_directions, 6);
  EXPECT_LT((full.x - x).norm(), 1e-3 * x.norm() + 2e-4);
  // kappa stays the depth's: the wall is no more reliable for its colour.
  EXPECT_FALSE(std::isfinite(full.condition) && full.condition < 1e6);
  // The residual is the depth's at the solution: its noise, 1e-3^2 per row.
  EXPECT_NEAR(full.residual / eq.weight_sum, 1e-6, 2e-7);
}

TEST(IcpPhotometric, TheColourMovesOnlyWhatTheDepthConstrains) {
  // The wall fixes alpha, beta and tz; gamma, tx and ty stay at the initial pose with colour or
  // without, and the colour refines the three the depth fixes.
  Eigen::Matrix<double, 6, 1> x;
  x << 0.002, -0.001, 0.0, 0.0, 0.0, 0.003;
  Eigen::Matrix<double, 6, 1> biased = x;  // the depth alone, off by a bias along tz
  biased(5) += 0.002;
  NormalEquations eq = wall_equations(biased, 0.0);
  const IcpStep depth_only = solve_icp_step(eq, 562.3);
  ASSERT_TRUE(depth_only.solvable);
  EXPECT_NEAR(depth_only.x(5), biased(5), 1e-9);
  add_photometric(eq, colour_equations(x, 0.001), 1.0, 1e-6);
  const IcpStep step = solve_icp_step(eq, 562.3);
  ASSERT_TRUE(step.solvable);
  EXPECT_EQ(step.constrained_directions, 3);
  EXPECT_FALSE(std::isfinite(step.condition) && step.condition < 1e6);
  for (const int free : {2, 3, 4}) EXPECT_NEAR(step.x(free), 0.0, 1e-12) << "direction " << free;
  // Between the depth's tz and the colour's, nearer the colour's: its rows are the stronger here.
  EXPECT_LT(step.x(5), biased(5) - 0.001);
  EXPECT_GT(step.x(5), x(5) - 1e-4);
  EXPECT_NEAR(step.x(0), x(0), 2e-4);
  EXPECT_NEAR(step.x(1), x(1), 2e-4);
  // The directions and their singular values are the depth's.
  EXPECT_LT((step.singular_values - depth_only.singular_values).norm(),
            1e-9 * depth_only.singular_values(0));
}

TEST(IcpConfigValidate, RejectsAPhotometricWeightOrThresholdOutOfRange) {
  IcpConfig c;
  c.photometric.weight = -1;
  EXPECT_FALSE(c.validate(3).ok());
  c.photometric.weight = 0;
  EXPECT_TRUE(c.validate(3).ok());
  c.photometric.huber_sigmas = 0;
  EXPECT_FALSE(c.validate(3).ok());
  c.photometric.huber_sigmas = 1.345;
  c.photometric.initial_huber = std::nan("");
  EXPECT_FALSE(c.validate(3).ok());
  c.photometric.initial_huber = 0.1;
  c.photometric.pixel_step = 0;
  EXPECT_FALSE(c.validate(3).ok());
  c.photometric.pixel_step = 17;
  EXPECT_FALSE(c.validate(3).ok());
  c.photometric.pixel_step = 16;
  EXPECT_TRUE(c.validate(3).ok());
  c.photometric.min_sigma = -0.01;
  EXPECT_FALSE(c.validate(3).ok());
  c.photometric.min_sigma = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(c.validate(3).ok());
  c.photometric.min_sigma = 0;
  EXPECT_TRUE(c.validate(3).ok());
}

TEST(IcpIncrement, IsARotationEvenForLargeAngles) {
  Eigen::Matrix<double, 6, 1> x;
  x << 0.5, -0.3, 0.8, 1, 2, 3;
  const Eigen::Isometry3d T = icp_increment(x);
  EXPECT_LT((T.linear() * T.linear().transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  EXPECT_EQ(T.translation(), Eigen::Vector3d(1, 2, 3));
}

TEST(IcpJudge, NamesTheFailingMetric) {
  IcpReliabilityThresholds t;
  IcpQuality q;
  t.min_pixel_fraction = 0.3;
  q.inliers = 5000;
  q.inlier_fraction = 0.8;
  q.pixel_fraction = 0.7;
  q.condition = 20;
  q.residual_per_weight = t.max_residual_per_weight / 2;
  std::string reason;
  EXPECT_TRUE(judge_icp(q, t, &reason));
  EXPECT_TRUE(reason.empty());
  q.condition = 1e5;
  EXPECT_FALSE(judge_icp(q, t, &reason));
  EXPECT_NE(reason.find("condition"), std::string::npos);
  q.condition = 20;
  q.inliers = 10;
  EXPECT_FALSE(judge_icp(q, t, &reason));
  EXPECT_NE(reason.find("inliers"), std::string::npos);
  q.inliers = 5000;
  q.pixel_fraction = 0.2;  // the information-weighted fraction alone would pass
  EXPECT_FALSE(judge_icp(q, t, &reason));
  EXPECT_NE(reason.find("pixel fraction"), std::string::npos);
}

TEST(IcpConfigValidate, RejectsFractionsOutsideZeroToOne) {
  IcpConfig c;
  EXPECT_TRUE(c.validate(3).ok());
  c.reliability.min_pixel_fraction = 1.5;
  EXPECT_FALSE(c.validate(3).ok());
  c.reliability.min_pixel_fraction = 0.3;
  c.reliability.min_inlier_fraction = std::nan("");
  const Status bad = c.validate(3);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("min_inlier_fraction"), std::string::npos);
}

TEST(IcpCpu, RecoversAKnownMotionInTheRoom) {
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
  const Eigen::Isometry3d motion = small_motion(2.0, {0.3, 1, 0.2}, {0.03, -0.02, 0.04});
  Pair pair = render_pair(scene, room_view(), motion, /*noise=*/false);
  reference::CpuNormalEquationSource source(pair.reference, pair.current, pair.k);
  auto result = run_icp(source, IcpConfig{}, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok()) << result.error().describe();
  const Eigen::Isometry3d error = pair.T_ref_cur.inverse() * result->T_ref_cur;
  EXPECT_LT(error.translation().norm(), 0.002);
  EXPECT_LT(rotation_deg(error), 0.1);
  EXPECT_TRUE(result->reliable()) << result->reason;
  EXPECT_GT(result->quality.iterations, 1);
  // The pyramid ran: some steps at the coarser levels, and at least one at full resolution.
  EXPECT_GT(result->quality.coarse_iterations, 0);
  EXPECT_LT(result->quality.coarse_iterations, result->quality.iterations);
  EXPECT_LT(result->quality.condition, IcpReliabilityThresholds{}.max_condition);
}

TEST(IcpCpu, AFlatWallIsIllConditionedAndUnreliable) {
  const synth::Scene wall = flat_wall();
  const Eigen::Isometry3d motion = small_motion(0.5, {0, 1, 0}, {0.02, 0.01, 0.0});
  Pair pair = render_pair(wall, Eigen::Isometry3d::Identity(), motion, /*noise=*/true);
  reference::CpuNormalEquationSource source(pair.reference, pair.current, pair.k);
  auto result = run_icp(source, IcpConfig{}, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok());
  EXPECT_GT(result->quality.condition, 1e3);
  EXPECT_FALSE(result->reliable());
  EXPECT_NE(result->reason.find("condition"), std::string::npos) << result->reason;
}

TEST(IcpCpu, TheTranslationConditionTellsAWallFromAViewThatFixesThePosition) {
  // A wall leaves two translations free: the kappa of the translation alone is far above
  // relocalization.max_translation_condition (100). The room fixes all three well within it.
  const double limit = 100;
  Pair wall = render_pair(flat_wall(), Eigen::Isometry3d::Identity(),
                          small_motion(0.5, {0, 1, 0}, {0.02, 0.01, 0.0}), /*noise=*/true);
  reference::CpuNormalEquationSource wall_source(wall.reference, wall.current, wall.k);
  auto on_wall = run_icp(wall_source, IcpConfig{}, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(on_wall.ok());
  EXPECT_GT(on_wall->quality.translation_condition, 5 * limit);
  Pair room = render_pair(synth::make_scene(synth::SceneKind::kRoom, 1), room_view(),
                          small_motion(2.0, {0.3, 1, 0.2}, {0.03, -0.02, 0.04}), /*noise=*/true);
  reference::CpuNormalEquationSource room_source(room.reference, room.current, room.k);
  auto in_room = run_icp(room_source, IcpConfig{}, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(in_room.ok());
  EXPECT_LT(in_room->quality.translation_condition, limit);
  EXPECT_GE(in_room->quality.translation_condition, 1);
}

TEST(IcpQuality, APositionIsFixedWhenAllButTheConditionPassAndTheTranslationIsConditioned) {
  IcpQuality q;
  q.iterations = 4;
  q.inliers = 5000;
  q.inlier_fraction = q.pixel_fraction = 0.8;
  q.residual_per_weight = 1e-6;
  q.condition = 1e4;  // fails the condition number (562.3)
  q.translation_condition = 20;
  const IcpReliabilityThresholds t;
  EXPECT_FALSE(judge_icp(q, t, nullptr));
  EXPECT_TRUE(fixes_position(q, t, 100));
  EXPECT_FALSE(fixes_position(q, t, 0));  // off
  IcpQuality sliding = q;
  sliding.translation_condition = 150;
  EXPECT_FALSE(fixes_position(sliding, t, 100));
  IcpQuality unpaired = q;
  unpaired.inlier_fraction = 0.3;  // fails a test beside the condition
  EXPECT_FALSE(fixes_position(unpaired, t, 100));
  IcpQuality not_run = q;
  not_run.iterations = 0;
  EXPECT_FALSE(fixes_position(not_run, t, 100));
}

TEST(IcpCpu, AFlatWallSolvedDegeneracyAwareKeepsTheSeedAlongTheWall) {
  // The wall constrains its normal translation and the two tilts; the in-plane translations and
  // the rotation about the normal come from the seed (the IMU's prediction in the scanner). A
  // seed right along the wall but off across it must end partial, right in all six directions.
  const synth::Scene wall = flat_wall();
  const Eigen::Isometry3d motion = small_motion(0.8, {1, 2, 0.5}, {0.02, 0.01, 0.015});
  Pair pair = render_pair(wall, Eigen::Isometry3d::Identity(), motion, /*noise=*/true);
  // Seed: 12 mm too far from the wall and tilted 0.6 deg, exact along it.
  const Eigen::Isometry3d seed = motion * small_motion(0.6, {1, -1, 0}, {0, 0, 0.012});
  IcpConfig config;
  config.keep_seed_in_degenerate_directions = true;
  reference::CpuNormalEquationSource source(pair.reference, pair.current, pair.k);
  auto result = run_icp(source, config, seed);
  ASSERT_TRUE(result.ok());
  EXPECT_FALSE(result->reliable());
  EXPECT_TRUE(result->partial()) << result->reason;
  EXPECT_EQ(result->quality.constrained_directions, 3);
  EXPECT_EQ(result->partial_directions(), 3);
  // The one translation it fixed is the distance to the wall (the reference's z).
  Eigen::Matrix3d normal_only = Eigen::Matrix3d::Zero();
  normal_only(2, 2) = 1.0;
  EXPECT_LT((result->fixed_translation - normal_only).norm(), 0.05) << result->fixed_translation;
  const Eigen::Isometry3d error = motion.inverse() * result->T_ref_cur;
  EXPECT_LT(rotation_deg(error), 0.1);
  EXPECT_LT(error.translation().norm(), 0.002);
  // The plain solve of the same start wanders along the wall instead.
  reference::CpuNormalEquationSource plain_source(pair.reference, pair.current, pair.k);
  auto plain = run_icp(plain_source, IcpConfig{}, seed);
  ASSERT_TRUE(plain.ok());
  EXPECT_FALSE(plain->partial());
  EXPECT_FALSE(plain->reliable());
  EXPECT_EQ(plain->partial_directions(), 0);
}

TEST(IcpCpu, DegeneracyAwareSolvingLeavesAWellConstrainedAlignmentUnchanged) {
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
  const Eigen::Isometry3d motion = small_motion(1.0, {0.3, 1, 0.2}, {0.02, -0.01, 0.015});
  Pair pair = render_pair(scene, room_view(), motion, false);
  IcpConfig aware;
  aware.keep_seed_in_degenerate_directions = true;
  reference::CpuNormalEquationSource a(pair.reference, pair.current, pair.k);
  reference::CpuNormalEquationSource b(pair.reference, pair.current, pair.k);
  auto with = run_icp(a, aware, Eigen::Isometry3d::Identity());
  auto without = run_icp(b, IcpConfig{}, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_TRUE(with->reliable()) << with->reason;
  EXPECT_FALSE(with->partial());
  EXPECT_EQ(with->quality.constrained_directions, 6);
  EXPECT_TRUE(with->fixed_translation.isIdentity());
  EXPECT_LT((with->T_ref_cur.matrix() - without->T_ref_cur.matrix()).norm(), 1e-9);
}

TEST(IcpCpu, DegenerateInputGivesAnUnreliableFinitePose) {
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
  Pair pair = render_pair(scene, room_view(), Eigen::Isometry3d::Identity(), false);
  // No valid pixels in the current frame.
  PreprocessedFrame empty = pair.current;
  for (auto& level : empty.vertices)
    for (auto& v : level.data) v.setZero();
  reference::CpuNormalEquationSource no_pixels(pair.reference, empty, pair.k);
  auto a = run_icp(no_pixels, IcpConfig{}, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(a.ok());
  EXPECT_FALSE(a->reliable());
  EXPECT_TRUE(a->T_ref_cur.matrix().allFinite());
  EXPECT_EQ(a->quality.inliers, 0u);

  // Every pair rejected: the start is 3 m off.
  reference::CpuNormalEquationSource far(pair.reference, pair.current, pair.k);
  Eigen::Isometry3d off = Eigen::Isometry3d::Identity();
  off.translation() = Eigen::Vector3d(0, 0, 3.0);
  auto b = run_icp(far, IcpConfig{}, off);
  ASSERT_TRUE(b.ok());
  EXPECT_FALSE(b->reliable());
  EXPECT_TRUE(b->T_ref_cur.matrix().allFinite());

  // A NaN start.
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan(0, 3) = std::numeric_limits<double>::quiet_NaN();
  auto c = run_icp(far, IcpConfig{}, nan);
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(c->reliable());
  EXPECT_TRUE(c->T_ref_cur.matrix().allFinite());
}

TEST(IcpCpu, ASingleIterationBudgetIsSpentAtFullResolution) {
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
  const Eigen::Isometry3d motion = small_motion(0.3, {0, 1, 0}, {0.005, 0, 0.003});
  Pair pair = render_pair(scene, room_view(), motion, false);
  reference::CpuNormalEquationSource source(pair.reference, pair.current, pair.k);
  IcpConfig config;
  config.max_total_iterations = 1;
  config.max_unsettled_iterations = 0;  // the cap fixed
  auto result = run_icp(source, config, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->quality.iterations, 1);
  EXPECT_EQ(result->quality.coarse_iterations, 0);
  // One Gauss-Newton step from a small offset lands close.
  const Eigen::Isometry3d error = pair.T_ref_cur.inverse() * result->T_ref_cur;
  EXPECT_LT(error.translation().norm(), 0.002);
}

TEST(IcpCpu, PastTheCapLevelZeroStepsOnUntilItsStepIsWithinTheNoise) {
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
  const Eigen::Isometry3d motion = small_motion(1.5, {0.3, 1, 0.2}, {0.02, -0.01, 0.015});
  Pair pair = render_pair(scene, room_view(), motion, /*noise=*/true);
  IcpConfig capped;
  capped.max_total_iterations = 1;
  capped.max_unsettled_iterations = 0;
  IcpConfig settling = capped;
  settling.max_unsettled_iterations = 10;
  reference::CpuNormalEquationSource a(pair.reference, pair.current, pair.k);
  reference::CpuNormalEquationSource b(pair.reference, pair.current, pair.k);
  auto one = run_icp(a, capped, Eigen::Isometry3d::Identity());
  auto more = run_icp(b, settling, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(one.ok() && more.ok());
  EXPECT_EQ(one->quality.iterations, 1);
  // One step from 2.6 cm and 1.5 deg off leaves the pose moving: level 0 steps on, and stops
  // once a step is within the frame's noise, before the limit.
  EXPECT_GT(more->quality.iterations, 1);
  EXPECT_LT(more->quality.iterations, 10);
  const double one_error = (pair.T_ref_cur.inverse() * one->T_ref_cur).translation().norm();
  const double more_error = (pair.T_ref_cur.inverse() * more->T_ref_cur).translation().norm();
  EXPECT_LT(more_error, 0.5 * one_error);
  EXPECT_LT(more_error, 0.002);
  EXPECT_TRUE(more->reliable()) << more->reason;
}

TEST(DepthNoiseModel, InformationIsTheInverseVarianceRelativeToTheLeastNoise) {
  const DepthNoiseModel noise;
  EXPECT_DOUBLE_EQ(noise.information(noise.z0), 1.0);
  EXPECT_NEAR(noise.information(2.4), std::pow(0.0012 / (0.0012 + 0.0019 * 4.0), 2), 1e-12);
  EXPECT_LT(noise.information(4.0), noise.information(2.0));
  EXPECT_DOUBLE_EQ((DepthNoiseModel{0.0, 0.0019, 0.4}).information(3.0), 1.0);  // a = 0: counts
}

TEST(IcpReduce, PixelsCountInTheInlierFractionByTheirInformation) {
  // Half the valid pixels near and paired, half far and rejected (their normals failed the gate).
  std::vector<reference::IcpRow> rows(4);
  for (int i = 0; i < 4; ++i) {
    rows[static_cast<std::size_t>(i)].valid = rows[static_cast<std::size_t>(i)].covered = true;
    rows[static_cast<std::size_t>(i)].z = i < 2 ? 1.0 : 4.0;
  }
  rows[0].w = rows[1].w = 0.9;
  rows[0].a << 0, 0, 0, 0, 0, 1;
  rows[1].a << 0, 0, 0, 0, 0, 1;
  const DepthNoiseModel noise;
  const NormalEquations eq = reference::icp_reduce(rows, noise);
  EXPECT_EQ(eq.inliers, 2u);
  EXPECT_EQ(eq.valid_pixels, 4u);
  EXPECT_NEAR(eq.valid_information, 2 * noise.information(1.0) + 2 * noise.information(4.0), 1e-12);
  EXPECT_NEAR(eq.inlier_information, 2 * noise.information(1.0), 1e-12);
  EXPECT_GT(eq.inlier_information / eq.valid_information, 0.99);
  const NormalEquations counted = reference::icp_reduce(rows, DepthNoiseModel{0, 0, 0});
  EXPECT_DOUBLE_EQ(counted.inlier_information / counted.valid_information, 0.5);
}

TEST(IcpReduce, ThePixelsTheReferenceDoesNotCoverAreCounted) {
  // Ten valid pixels at 1 m: four the reference does not cover (the view turned past the model),
  // and of the six it covers five paired.
  std::vector<reference::IcpRow> rows(10);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    rows[i].valid = true;
    rows[i].z = 1.0;
    rows[i].covered = i >= 4;
    if (i >= 5) {
      rows[i].w = 0.9;
      rows[i].a << 0, 0, 0, 0, 0, 1;
    }
  }
  const NormalEquations eq = reference::icp_reduce(rows, DepthNoiseModel{});
  EXPECT_EQ(eq.uncovered_pixels, 4u);
  EXPECT_NEAR(eq.covered_fraction(), 0.6, 1e-12);
  EXPECT_NEAR(eq.covered_inlier_fraction(), 5.0 / 6.0, 1e-12);
  EXPECT_NEAR(eq.inlier_fraction(), 0.5, 1e-12);  // over every valid pixel
  EXPECT_NEAR(eq.covered_inlier_fraction() * eq.covered_fraction(), eq.inlier_fraction(), 1e-12);
  // Nothing covered: no fraction of it.
  for (reference::IcpRow& row : rows) row.covered = false, row.w = 0;
  EXPECT_EQ(reference::icp_reduce(rows, DepthNoiseModel{}).covered_inlier_fraction(), 0.0);
}

// Normal equations of a quadratic cost whose minimum is the pose `target` (as T_ref_cur), with
// AtA's singular values `s` along the coordinate axes and a noise floor in the residual: the
// Gauss-Newton step from any pose lands on the minimum.
class QuadraticSource : public NormalEquationSource {
 public:
  // `paired`: the inlier fraction the source reports (of the information and of the pixels).
  QuadraticSource(const Eigen::Matrix<double, 6, 1>& s, const Eigen::Matrix<double, 6, 1>& target,
                  double paired = 1.0)
      : AtA_(s.asDiagonal()), target_(target), paired_(paired) {}
  int levels() const override { return 1; }
  Result<NormalEquations> evaluate(int, const Eigen::Isometry3d& T, float, float) override {
    Eigen::Matrix<double, 6, 1> at;
    const Eigen::AngleAxisd aa(T.linear());
    at.head<3>() = aa.angle() * aa.axis();
    at.tail<3>() = T.translation();
    const Eigen::Matrix<double, 6, 1> dx = target_ - at;
    NormalEquations eq;
    eq.AtA = AtA_;
    eq.Atb = AtA_ * dx;
    eq.weight_sum = 5000;
    eq.btb = dx.dot(AtA_ * dx) + 1e-6 * eq.weight_sum;  // a residual of 1 mm per unit weight
    eq.inliers = 5000;
    eq.inlier_information = 5000;
    eq.valid_pixels = static_cast<std::uint64_t>(5000 / paired_);
    eq.valid_information = 5000 / paired_;
    return eq;
  }

 private:
  Eigen::Matrix<double, 6, 6> AtA_;
  Eigen::Matrix<double, 6, 1> target_;
  double paired_;
};

// The strong directions need 1 mm / 0.06 deg of motion; tz, kappa 200, the weak one, `weak_m`.
Eigen::Matrix<double, 6, 1> gate_target(double weak_m) {
  Eigen::Matrix<double, 6, 1> x;
  x << 0.001, -0.001, 0.0005, 0.001, -0.001, weak_m;
  return x;
}

Eigen::Matrix<double, 6, 1> gate_singular_values() {
  Eigen::Matrix<double, 6, 1> s;
  s << 2e4, 2e4, 2e4, 2e4, 2e4,
      100;  // tz: kappa 200, between seed_gate_condition and max_condition
  return s;
}

IcpConfig gated_config() {
  IcpConfig config;
  config.keep_seed_in_degenerate_directions = true;
  config.seed_sigma_rotation = 0.0005;
  config.seed_sigma_translation = 0.001;
  return config;
}

TEST(IcpSeedGate, AWeakDirectionThatMovesFarFromTheSeedKeepsTheSeed) {
  // ICP pulls 8 mm along tz against a 1 mm prediction sigma (and its own ~0.1 mm there).
  QuadraticSource source(gate_singular_values(), gate_target(0.008));
  auto result = run_icp(source, gated_config(), Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok());
  EXPECT_FALSE(result->reliable());
  EXPECT_TRUE(result->partial()) << result->reason;
  EXPECT_EQ(result->quality.constrained_directions, 5);
  EXPECT_GT(result->quality.seed_disagreement, 7.0);
  EXPECT_NE(result->reason.find("kappa 200"), std::string::npos) << result->reason;
  // tz stays at the seed; the strong directions take ICP's motion.
  EXPECT_NEAR(result->T_ref_cur.translation().z(), 0.0, 1e-9);
  EXPECT_NEAR(result->T_ref_cur.translation().x(), 0.001, 1e-6);
  EXPECT_NEAR(result->T_ref_cur.translation().y(), -0.001, 1e-6);
  Eigen::Matrix3d fixed_xy = Eigen::Matrix3d::Identity();
  fixed_xy(2, 2) = 0;
  EXPECT_LT((result->fixed_translation - fixed_xy).norm(), 1e-9) << result->fixed_translation;
}

TEST(IcpSeedGate, AMoveWithinTheUncertaintyIsTakenWhole) {
  QuadraticSource source(gate_singular_values(), gate_target(0.002));  // 2 sigma
  auto result = run_icp(source, gated_config(), Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result->reliable()) << result->reason;
  EXPECT_FALSE(result->partial());
  EXPECT_NEAR(result->quality.seed_disagreement, 2.0, 0.1);
  EXPECT_NEAR(result->T_ref_cur.translation().z(), 0.002, 1e-6);
}

TEST(IcpSeedGate, StrongDirectionsAndUnknownSeedsAreNotGated) {
  // 8 mm along a strongly constrained direction is ICP's to decide.
  Eigen::Matrix<double, 6, 1> strong = gate_target(0.0);
  strong(3) = 0.008;
  QuadraticSource a(gate_singular_values(), strong);
  auto along_strong = run_icp(a, gated_config(), Eigen::Isometry3d::Identity());
  ASSERT_TRUE(along_strong.ok());
  EXPECT_TRUE(along_strong->reliable()) << along_strong->reason;
  EXPECT_NEAR(along_strong->T_ref_cur.translation().x(), 0.008, 1e-6);
  // Without a seed uncertainty there is no gate.
  IcpConfig unknown = gated_config();
  unknown.seed_sigma_rotation = unknown.seed_sigma_translation = 0;
  QuadraticSource b(gate_singular_values(), gate_target(0.008));
  auto ungated = run_icp(b, unknown, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(ungated.ok());
  EXPECT_TRUE(ungated->reliable()) << ungated->reason;
  EXPECT_EQ(ungated->quality.seed_disagreement, 0.0);
  EXPECT_NEAR(ungated->T_ref_cur.translation().z(), 0.008, 1e-6);
}

IcpConfig prior_config() {
  IcpConfig config;
  config.seed_prior = true;
  config.seed_sigma_rotation = 0.0005;
  config.seed_sigma_translation = 0.001;
  return config;
}

TEST(IcpSeedPrior, EachDirectionIsWeighedBetweenTheDepthAndTheSeed) {
  // The depth's information along an axis: s_i / (c s^2), c = 49 pixels, s^2 = the larger of
  // r/sum(w) (1 mm^2) and the sensor's least noise (1.2 mm)^2.
  const Eigen::Matrix<double, 6, 1> s = gate_singular_values();
  const double scale = 1 / (49 * 0.0012 * 0.0012);
  const double prior = 1 / (0.001 * 0.001);
  QuadraticSource source(s, gate_target(0.008));
  auto result = run_icp(source, prior_config(), Eigen::Isometry3d::Identity());
  ASSERT_TRUE(result.ok());
  // tz (s = 100): depth 1.4e6 against the prediction's 1e6, 59 % of ICP's 8 mm.
  const double weak = 0.008 * s(5) * scale / (s(5) * scale + prior);
  EXPECT_NEAR(result->T_ref_cur.translation().z(), weak, 1e-5);
  EXPECT_LT(result->T_ref_cur.translation().z(), 0.006);
  // tx (s = 2e4): the depth outweighs the prediction 280 to 1.
  EXPECT_NEAR(result->T_ref_cur.translation().x(), 0.001, 1e-5);
  EXPECT_TRUE(result->reliable()) << result->reason;
  // Without a translation sigma there is no prior: ICP's pose whole.
  IcpConfig rotation_only = prior_config();
  rotation_only.seed_sigma_translation = 0;
  QuadraticSource again(s, gate_target(0.008));
  auto depth_only = run_icp(again, rotation_only, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(depth_only.ok());
  EXPECT_NEAR(depth_only->T_ref_cur.translation().z(), 0.008, 1e-6);
  EXPECT_EQ(depth_only->quality.seed_chi2, 0.0);
}

TEST(IcpSeedPrior, AFrameThatPairsFewPixelsButAgreesWithTheSeedIsReliable) {
  Eigen::Matrix<double, 6, 1> s;
  s.setConstant(2e4);
  QuadraticSource agreeing(s, gate_target(0.001), 0.3);  // 30 % paired, under the 40 % test
  auto agreed = run_icp(agreeing, prior_config(), Eigen::Isometry3d::Identity());
  ASSERT_TRUE(agreed.ok());
  EXPECT_TRUE(agreed->reliable()) << agreed->reason;
  EXPECT_TRUE(agreed->quality.agreed_with_seed);
  EXPECT_GT(agreed->quality.seed_chi2, 0.0);
  EXPECT_LT(agreed->quality.seed_chi2, 22.46);
  // The test needs the seed's sigmas, not the prior in the solve.
  IcpConfig without_prior = prior_config();
  without_prior.seed_prior = false;
  QuadraticSource again(s, gate_target(0.001), 0.3);
  auto agreed_alone = run_icp(again, without_prior, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(agreed_alone.ok());
  EXPECT_TRUE(agreed_alone->quality.agreed_with_seed) << agreed_alone->reason;
  EXPECT_NEAR(agreed_alone->T_ref_cur.translation().x(), 0.001, 1e-9);
  // 6 mm away from a 1 mm prediction: the pairing test stands.
  Eigen::Matrix<double, 6, 1> far = gate_target(0.001);
  far(3) = 0.006;
  QuadraticSource disagreeing(s, far, 0.3);
  auto refused = run_icp(disagreeing, prior_config(), Eigen::Isometry3d::Identity());
  ASSERT_TRUE(refused.ok());
  EXPECT_FALSE(refused->reliable());
  EXPECT_FALSE(refused->quality.agreed_with_seed);
  EXPECT_GT(refused->quality.seed_chi2, 22.46);
  EXPECT_NE(refused->reason.find("inlier fraction"), std::string::npos) << refused->reason;
  // Under half the pairing threshold, agreement alone does not make a frame reliable.
  QuadraticSource scarce(s, gate_target(0.001), 0.15);
  auto too_few = run_icp(scarce, prior_config(), Eigen::Isometry3d::Identity());
  ASSERT_TRUE(too_few.ok());
  EXPECT_FALSE(too_few->reliable());
}

// A wall-like system: three strong directions, three that the depth barely constrains.
TEST(IcpPartial, APartialResultNeedsOnlyItsOwnPairingFloor) {
  Eigen::Matrix<double, 6, 1> s;
  s << 2e4, 2e4, 1, 1, 1, 2e4;
  IcpConfig config;
  config.keep_seed_in_degenerate_directions = true;
  // 25 % paired: under reliability's 40 %, so no partial result by default.
  QuadraticSource scarce(s, gate_target(0.001), 0.25);
  auto refused = run_icp(scarce, config, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(refused.ok());
  EXPECT_FALSE(refused->partial());
  EXPECT_NE(refused->reason.find("inlier fraction"), std::string::npos) << refused->reason;
  // With the floor at 15 %, the same alignment is partial and fixes the strong directions.
  config.partial_min_fraction = 0.15;
  QuadraticSource again(s, gate_target(0.001), 0.25);
  auto partial = run_icp(again, config, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(partial.ok());
  EXPECT_TRUE(partial->partial()) << partial->reason;
  EXPECT_EQ(partial->quality.constrained_directions, 3);
  EXPECT_NEAR(partial->T_ref_cur.translation().z(), 0.001, 1e-6);
  EXPECT_NEAR(partial->T_ref_cur.translation().x(), 0.0, 1e-9);  // weak: the seed's
  // The floor never makes a reliable result of it, and under it nothing is taken.
  QuadraticSource sparse(s, gate_target(0.001), 0.1);
  auto below = run_icp(sparse, config, Eigen::Isometry3d::Identity());
  ASSERT_TRUE(below.ok());
  EXPECT_FALSE(below->partial());
  EXPECT_FALSE(below->reliable());
  config.partial_min_fraction = 1.5;
  EXPECT_FALSE(config.validate(1).ok());
}

TEST(IcpConfigValidate, RejectsBadSeedGateSettings) {
  IcpConfig config;
  config.seed_sigma_translation = -0.001;
  EXPECT_FALSE(config.validate(3).ok());
  config = IcpConfig{};
  config.seed_gate_condition = 0.5;
  EXPECT_FALSE(config.validate(3).ok());
  config = IcpConfig{};
  config.seed_gate_sigmas = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(config.validate(3).ok());
  config = IcpConfig{};
  config.correlated_pixels = 0.5;
  EXPECT_FALSE(config.validate(3).ok());
  config = IcpConfig{};
  config.seed_agreement_chi2 = -1;
  EXPECT_FALSE(config.validate(3).ok());
}

TEST(IcpConfigValidate, RejectsBadSettlingSettings) {
  IcpConfig config;
  config.max_unsettled_iterations = -1;
  Status bad = config.validate(3);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("max_unsettled_iterations"), std::string::npos);
  config = IcpConfig{};
  config.settled_chi2 = 0;
  bad = config.validate(3);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("settled_chi2"), std::string::npos);
  config.settled_chi2 = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(config.validate(3).ok());
}

}  // namespace
}  // namespace imufusion
