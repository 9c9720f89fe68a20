// The relocalization driver's decisions on a search whose best fit is not the only one: it waits
// for the next search, from another view, to put the frame at the same correction of its
// estimate; and on one whose best fit nearly constrained every direction: the next lost frame
// searches again. The model is a floor plane, the alignments a scripted stand-in for the GPU's.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "inertial_test_fixtures.hpp"
#include "mesh_test_fixtures.hpp"
#include "scan/relocalization.hpp"

namespace imufusion {
namespace {

// A frame's fits, in the order the search asks for them: where each candidate's ICP puts the
// frame (relative to its estimate) and whether it is reliable, a fit but for the condition
// number, or no fit.
enum class Fit { kReliable, kIllConditioned, kNone };
struct ScriptedFit {
  Fit fit = Fit::kNone;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // world, m, from the frame's estimate
  double residual_per_weight = 1e-6;                 // m^2
  double inlier_fraction = 0.8;                      // of a fit (kNone: 0.1)
};

class ScriptedModel : public ModelAligner {
 public:
  ScriptedModel()
      : volume_(test::make_sdf_volume([](const Eigen::Vector3d& p) { return p.z() - 2.0; },
                                      Eigen::Vector3i(-10, -10, 22), Eigen::Vector3i(10, 10, 27))) {
  }

  std::vector<ScriptedFit> fits;  // this search's candidates, in order
  double ill_condition = 1e4;     // an ill-conditioned fit's kappa: a wall's, by default
  // ...and its translation's (IcpQuality::translation_condition): a wall's two free directions
  double ill_translation_condition = std::numeric_limits<double>::infinity();
  Eigen::Isometry3d estimate;  // the frame's estimate
  int searches = 0;            // searches started (frame_points calls)
  double lift = 0;             // m: the frame's points this far above the floor at the estimate
  /// Only ICP started within 1 cm of the estimate moved by this (world, m) settles, at fits[0]
  /// (the others find no fit); unset: each candidate in turn takes the next fit.
  std::optional<Eigen::Vector3d> fit_only_from;
  std::vector<Eigen::Vector3d> seeds;  // where each ICP started

  Status load_frame(const DepthView&, FrameTimings&) override { return {}; }
  Status set_reference(const Eigen::Isometry3d&, FrameTimings&) override { return {}; }
  Result<Placement> place(const DepthView&, const Eigen::Isometry3d& seed, FrameTimings&) override {
    seeds.push_back(seed.translation());
    ScriptedFit scripted = next_ < fits.size() ? fits[next_] : ScriptedFit{};
    ++next_;
    if (fit_only_from)
      scripted = (seed.translation() - estimate.translation() - *fit_only_from).norm() < 0.01 &&
                         !fits.empty()
                     ? fits.front()
                     : ScriptedFit{};
    Placement p;
    p.T_world_camera = estimate;
    p.T_world_camera.translation() += scripted.offset;
    IcpQuality& q = p.icp.quality;
    q.iterations = 3;
    q.converged = true;
    q.inliers = 5000;
    q.inlier_fraction = scripted.fit == Fit::kNone ? 0.1 : scripted.inlier_fraction;
    q.pixel_fraction = q.inlier_fraction;
    q.condition = scripted.fit == Fit::kIllConditioned ? ill_condition : 100;
    q.translation_condition = scripted.fit == Fit::kIllConditioned ? ill_translation_condition : 10;
    q.residual_per_weight = scripted.residual_per_weight;
    p.icp.verdict =
        scripted.fit == Fit::kReliable ? IcpVerdict::kReliable : IcpVerdict::kUnreliable;
    return p;
  }
  IcpReliabilityThresholds reliability(const DepthView&) const override { return {}; }
  // A patch of the floor 2 m below the camera (camera frame: z forward).
  Result<FramePoints> frame_points(int) override {
    ++searches;
    next_ = 0;
    FramePoints out;
    for (int i = -5; i <= 5; ++i)
      for (int j = -5; j <= 5; ++j) out.points.emplace_back(0.1 * i, 0.1 * j, 2.0 - lift);
    return out;
  }
  Result<HostVolume> model_snapshot() const override { return volume_; }

 private:
  HostVolume volume_;
  std::size_t next_ = 0;
};

class RelocalizationDriverTest : public ::testing::Test {
 protected:
  RelocalizationDriverTest() {
    config.relocalization.interval = 5;
    driver = RelocalizationDriver(config);
  }

  // Lost frame k (30 fps) at an estimate that moves 1 cm a frame, the last fully constrained
  // frame `constrained` (a second before frame 0 by default); the search's outcome.
  std::optional<ModelAligner::Placement> lost_frame(int k, int constrained = -30) {
    RelocalizationDriver::Frame f;
    f.timestamp = k / 30.0;
    f.constrained_time = constrained / 30.0;
    f.lost = true;
    f.rotation_from_imu = true;
    f.partial_directions = partial_directions;
    f.T_world_estimate.translation() = Eigen::Vector3d(0.01 * k, 0, 0);
    f.lost_at = f.T_world_estimate.translation();
    model.estimate = f.T_world_estimate;
    FrameTimings timings;
    auto out = driver.on_frame(f, DepthView{}, model, timings);
    EXPECT_TRUE(out.ok());
    return out.ok() ? out->found : std::nullopt;
  }

  // Whether a search placed lost frame k at its estimate moved by `correction`.
  bool placed_at_correction(const std::optional<ModelAligner::Placement>& found, int k) const {
    const Eigen::Vector3d expected = Eigen::Vector3d(0.01 * k, 0, 0) + correction;
    return found && (found->T_world_camera.translation() - expected).norm() < 1e-9;
  }

  ReconstructorConfig config;
  RelocalizationDriver driver;
  ScriptedModel model;
  int partial_directions = 0;  // the lost frames' partial ICP from the seed (0: not partial)
  const Eigen::Vector3d correction{0.2, -0.1, 0};  // where the camera is, from its estimate
  const Eigen::Vector3d elsewhere{-0.3, 0.4, 0};   // another fit, more than 2 cells away
  const Eigen::Vector3d slid{0.0, 0.4, 0};         // that fit in the next view, 0.3 m on
  // An ill-conditioned fit's translation kappa where it is a rival: its position fixed (within
  // relocalization.max_translation_condition, 100), as where a wall meets the floor.
  static constexpr double kRivalTranslationCondition = 20;
};

TEST_F(RelocalizationDriverTest, AnUnambiguousFitEndsTheLossAtOnce) {
  model.fits = {{Fit::kReliable, correction}, {Fit::kNone, elsewhere}};
  for (int k = 1; k < 5; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 0);
  EXPECT_TRUE(placed_at_correction(lost_frame(5), 5));
}

TEST_F(RelocalizationDriverTest, AnAmbiguousFitWaitsForTheNextFrameToConfirmIt) {
  model.ill_translation_condition = kRivalTranslationCondition;
  model.fits = {{Fit::kReliable, correction}, {Fit::kIllConditioned, elsewhere}};
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 1);
  // The next lost frame searches at once: its best fit needs the same correction, while the
  // other fit slid on.
  model.fits = {{Fit::kReliable, correction}, {Fit::kIllConditioned, slid}};
  EXPECT_TRUE(placed_at_correction(lost_frame(6), 6));
  EXPECT_EQ(model.searches, 2);
}

TEST_F(RelocalizationDriverTest, AnAmbiguousFitAtAnotherCorrectionIsNotAccepted) {
  model.ill_translation_condition = kRivalTranslationCondition;
  model.fits = {{Fit::kReliable, correction}, {Fit::kIllConditioned, elsewhere}};
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
  // The confirming search's best fit lies 0.3 m from the first one's correction: neither ends
  // the loss, and the searches go back to every fifth lost frame.
  const Eigen::Vector3d moved = correction + Eigen::Vector3d(0, 0.3, 0);
  model.fits = {{Fit::kReliable, moved}, {Fit::kIllConditioned, slid}};
  EXPECT_FALSE(lost_frame(6));
  for (int k = 7; k <= 10; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 2);
  // The next regular search agrees with the confirming one.
  model.fits = {{Fit::kReliable, moved}, {Fit::kIllConditioned, elsewhere}};
  EXPECT_TRUE(lost_frame(11));
  EXPECT_EQ(model.searches, 3);
}

TEST_F(RelocalizationDriverTest, AReliableFitThatRepeatsElsewhereKeepsTheViewAmbiguous) {
  // A second place fits every view in every direction (a repeated structure): no search ends
  // the loss.
  model.fits = {{Fit::kReliable, correction}, {Fit::kReliable, elsewhere}};
  for (int k = 1; k <= 30; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 6);  // frames 5 and 6 (its confirmation), then every fifth
}

TEST_F(RelocalizationDriverTest, AFitElsewhereWhoseTranslationSlidesIsNoRival) {
  // The view is mostly wall: the fit elsewhere pairs it with half the best fit's residual and
  // as much of the view, but its translation slides (kappa 1e4, translation kappa infinite): it
  // stopped where the search started it, and the best fit, which also pairs what fixes the
  // slide, is taken at once.
  model.fits = {{Fit::kReliable, correction, 1e-6}, {Fit::kIllConditioned, elsewhere, 0.5e-6}};
  for (int k = 1; k <= 4; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_TRUE(placed_at_correction(lost_frame(5), 5));
  // The same fit with its position fixed is a place for the frame too: a rival.
  driver = RelocalizationDriver(config);
  model.ill_translation_condition = kRivalTranslationCondition;
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
}

TEST_F(RelocalizationDriverTest, AFitElsewhereThatExplainsTheFrameWorseIsNoRival) {
  // The fit elsewhere pairs the frame with residuals whose mean square is twice the
  // relocalization.rival_residual_ratio times the best fit's: the best one is taken at once.
  const double ratio = config.relocalization.rival_residual_ratio;
  ASSERT_GT(ratio, 1);
  model.ill_translation_condition = kRivalTranslationCondition;
  model.fits = {{Fit::kReliable, correction, 1e-6},
                {Fit::kIllConditioned, elsewhere, 2 * ratio * 1e-6}};
  for (int k = 1; k <= 4; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_TRUE(placed_at_correction(lost_frame(5), 5));
}

TEST_F(RelocalizationDriverTest, AFitElsewhereWithinTheRatioKeepsTheViewAmbiguous) {
  // The same fit elsewhere, its mean square residual half the ratio times the best's: a rival.
  const double ratio = config.relocalization.rival_residual_ratio;
  model.ill_translation_condition = kRivalTranslationCondition;
  model.fits = {{Fit::kReliable, correction, 1e-6},
                {Fit::kIllConditioned, elsewhere, 0.5 * ratio * 1e-6}};
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
  // With the ratio off, any fit elsewhere is a rival, however badly it explains the frame (30
  // times the best's mean square, within the residual test's 4.22e-5 m^2).
  config.relocalization.rival_residual_ratio = 0;
  driver = RelocalizationDriver(config);
  model.fits = {{Fit::kReliable, correction, 1e-6}, {Fit::kIllConditioned, elsewhere, 30e-6}};
  for (int k = 6; k <= 10; ++k) EXPECT_FALSE(lost_frame(k));
}

TEST_F(RelocalizationDriverTest, AFitElsewhereThatPairsLessOfTheViewIsNoRival) {
  // The fit elsewhere has the best fit's residual but pairs half its inlier fraction (a wall of
  // the view fits there): no rival, and the best fit is taken at once.
  const double ratio = config.relocalization.rival_inlier_ratio;
  ASSERT_GT(ratio, 0.5);
  model.fits = {{Fit::kReliable, correction, 1e-6, 0.8}, {Fit::kReliable, elsewhere, 1e-6, 0.4}};
  for (int k = 1; k <= 4; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_TRUE(placed_at_correction(lost_frame(5), 5));
  // Pairing nearly as much as the best one, it is a rival again.
  driver = RelocalizationDriver(config);
  model.fits = {{Fit::kReliable, correction, 1e-6, 0.8},
                {Fit::kReliable, elsewhere, 1e-6, 0.8 * (1 + ratio) / 2}};
  for (int k = 1; k <= 30; ++k) EXPECT_FALSE(lost_frame(k));
}

TEST_F(RelocalizationDriverTest, AFitWhereTheCameraCannotBeIsNeitherAPlaceNorARival) {
  // Lost at frame -1: at frame 5, 0.2 s later, a hand-held camera (inertial.max_speed, 2 m/s)
  // is within 0.4 m of where it was lost. The fit 0.5 m away rivals nothing there, and the one
  // 0.22 m away is taken.
  ASSERT_NEAR(config.inertial.max_speed, 2.0, 1e-12);
  model.fits = {{Fit::kReliable, correction}, {Fit::kReliable, elsewhere}};
  for (int k = 1; k <= 4; ++k) EXPECT_FALSE(lost_frame(k, -1));
  EXPECT_TRUE(placed_at_correction(lost_frame(5, -1), 5));
  // The farther fit alone is no place at frame 5, and is one at the next search (frame 10,
  // 0.37 s, 0.73 m).
  driver = RelocalizationDriver(config);
  model.fits = {{Fit::kReliable, elsewhere}};
  for (int k = 1; k <= 9; ++k) EXPECT_FALSE(lost_frame(k, -1));
  const auto found = lost_frame(10, -1);
  ASSERT_TRUE(found);
  EXPECT_LT((found->T_world_camera.translation() - Eigen::Vector3d(0.1, 0, 0) - elsewhere).norm(),
            1e-9);
}

TEST_F(RelocalizationDriverTest, AFrameThatIsNotLostForgetsTheCorrectionWaitingForConfirmation) {
  model.ill_translation_condition = kRivalTranslationCondition;
  model.fits = {{Fit::kReliable, correction}, {Fit::kIllConditioned, elsewhere}};
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
  RelocalizationDriver::Frame tracked;
  tracked.timestamp = 6 / 30.0;
  FrameTimings timings;
  ASSERT_TRUE(driver.on_frame(tracked, DepthView{}, model, timings).ok());
  // A new loss: its first search is ambiguous again and ends nothing.
  for (int k = 7; k <= 11; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 2);
}

TEST_F(RelocalizationDriverTest, AFitThatNearlyConstrainsEveryDirectionSearchesAgainAtOnce) {
  // The view leaves a wall: the search's fit fails only the condition number, within
  // relocalization.near_fit_condition_factor (6) of its limit (562.3).
  model.ill_condition = 2000;
  model.fits = {{Fit::kIllConditioned, correction}};
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 1);
  EXPECT_FALSE(lost_frame(6));  // searches again, and again finds the fit short
  EXPECT_EQ(model.searches, 2);
  model.fits = {{Fit::kReliable, correction}};
  EXPECT_TRUE(placed_at_correction(lost_frame(7), 7));
  EXPECT_EQ(model.searches, 3);
}

TEST_F(RelocalizationDriverTest, AWallsFitWaitsForTheNextRegularSearch) {
  // kappa 1e4, 18 times the limit: the view is a wall, and the next frames search no sooner.
  model.fits = {{Fit::kIllConditioned, correction}};
  for (int k = 1; k <= 9; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 1);
  EXPECT_FALSE(lost_frame(10));
  EXPECT_EQ(model.searches, 2);
}

TEST_F(RelocalizationDriverTest, TheNearFitRetryCanBeTurnedOff) {
  config.relocalization.near_fit_condition_factor = 0;
  driver = RelocalizationDriver(config);
  model.ill_condition = 2000;
  model.fits = {{Fit::kIllConditioned, correction}};
  for (int k = 1; k <= 9; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 1);
}

TEST_F(RelocalizationDriverTest, WithTheGyroAFitThatFixesThePositionEndsTheLoss) {
  // The view leaves a wall: kappa 1e4 along the rotation about the wall's normal, but the
  // translation alone is well conditioned (kappa 20, within relocalization.
  // max_translation_condition, 100): the search started at the gyro's orientation places it.
  ASSERT_NEAR(config.relocalization.max_translation_condition, 100, 1e-12);
  model.ill_translation_condition = 20;
  model.fits = {{Fit::kIllConditioned, correction}};
  for (int k = 1; k <= 4; ++k) EXPECT_FALSE(lost_frame(k));
  const auto found = lost_frame(5);
  EXPECT_TRUE(placed_at_correction(found, 5));
  ASSERT_TRUE(found);
  EXPECT_TRUE(found->icp.reliable());
  EXPECT_TRUE(found->icp.reason.empty()) << found->icp.reason;
}

TEST_F(RelocalizationDriverTest, AFitWhoseTranslationSlidesOrWithTheLimitOffDoesNot) {
  // Its translation's kappa 150 (above the limit: it may slide along the wall), or the limit
  // off: no search of ten lost frames ends the loss.
  for (const auto& [limit, translation] : {std::pair{100.0, 150.0}, std::pair{0.0, 20.0}}) {
    config.relocalization.max_translation_condition = limit;
    driver = RelocalizationDriver(config);
    model.ill_translation_condition = translation;
    model.fits = {{Fit::kIllConditioned, correction}};
    for (int k = 1; k <= 10; ++k) EXPECT_FALSE(lost_frame(k)) << limit << " " << translation;
  }
  EXPECT_EQ(model.searches, 4);  // frames 5 and 10 of each
}

TEST_F(RelocalizationDriverTest, AViewThatFixesMoreThanAPlaneSearchesAtEveryLostFrame) {
  // Partial ICP from the seed fixed 4 directions, one more than a wall: the view is leaving it,
  // and each lost frame searches (a wall's 3 wait for the regular search).
  model.fits = {{Fit::kIllConditioned, correction}};
  partial_directions = 3;
  for (int k = 1; k <= 4; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 0);
  partial_directions = 4;
  for (int k = 5; k <= 7; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 3);
  partial_directions = 3;
  for (int k = 8; k <= 11; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_EQ(model.searches, 3);
  EXPECT_FALSE(lost_frame(12));  // five lost frames after the last search
  EXPECT_EQ(model.searches, 4);
}

TEST_F(RelocalizationDriverTest, WithTheGyroTheSearchStartsICPAtTheEstimateItself) {
  // The frame's points lie 15 cm (3 cells) off the floor at the estimate: the distance field's
  // candidates are all away from it, while ICP from the estimate settles (the field's coarse
  // grid missed the place).
  model.lift = 0.15;
  model.fit_only_from = Eigen::Vector3d::Zero();
  model.fits = {{Fit::kReliable, correction}};
  for (int k = 1; k <= 4; ++k) EXPECT_FALSE(lost_frame(k));
  EXPECT_TRUE(placed_at_correction(lost_frame(5), 5));
  ASSERT_FALSE(model.seeds.empty());
  EXPECT_LT((model.seeds.front() - Eigen::Vector3d(0.05, 0, 0)).norm(), 1e-9);
  EXPECT_GT(model.seeds.size(), 1u);  // the field's candidates too
}

TEST_F(RelocalizationDriverTest, TheConfirmingSearchStartsICPWhereTheLastSearchFoundTheFrame) {
  // An ambiguous fit at the correction; in the next view, only ICP started at the estimate moved
  // by that correction settles there (the field's candidates all lie 15 cm off it).
  model.lift = 0.15;
  model.ill_translation_condition = kRivalTranslationCondition;
  model.fits = {{Fit::kReliable, correction}, {Fit::kIllConditioned, elsewhere}};
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
  model.fit_only_from = correction;
  model.fits = {{Fit::kReliable, correction}};
  EXPECT_TRUE(placed_at_correction(lost_frame(6), 6));
}

TEST_F(RelocalizationDriverTest, AFitThatFixesEveryDirectionIsPreferredToOnePlacedByItsPosition) {
  // A fit elsewhere passes only by its translation's condition (kappa 1e4, translation 20) and
  // explains the view with a lower residual; the fit at the correction fixes every direction.
  // The best is the latter: the other is its rival, and the next view, where the rival slid
  // on, confirms it.
  model.ill_translation_condition = 20;
  model.fits = {{Fit::kIllConditioned, elsewhere, 0.5e-6}, {Fit::kReliable, correction, 1e-6}};
  for (int k = 1; k <= 5; ++k) EXPECT_FALSE(lost_frame(k));
  model.fits = {{Fit::kIllConditioned, slid, 0.5e-6}, {Fit::kReliable, correction, 1e-6}};
  EXPECT_TRUE(placed_at_correction(lost_frame(6), 6));
}

// A box room, 2.4 x 1.6 x 1.2 m (z up), and a camera in it that turned and moved while the scan
// was lost without a gyroscope: the frame's points are the room seen from the true pose, and
// ICP (scripted) settles only from a seed within its basin around that pose.
class TurnedRoomModel : public ModelAligner {
 public:
  TurnedRoomModel()
      : volume_(test::make_sdf_volume(
            [](const Eigen::Vector3d& p) {
              return std::min({p.x(), 2.4 - p.x(), p.y(), 1.6 - p.y(), p.z(), 1.2 - p.z()});
            },
            Eigen::Vector3i(-1, -1, -1), Eigen::Vector3i(16, 11, 8), 0.02f)) {}

  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Isometry3d> seeds;  // where ICP was started
  // kappa of a fit in the basin, and of its translation alone: reliable up to 562.3
  double basin_condition = 100, basin_translation_condition = 10;

  Status load_frame(const DepthView&, FrameTimings&) override { return {}; }
  Status set_reference(const Eigen::Isometry3d&, FrameTimings&) override { return {}; }
  Result<Placement> place(const DepthView&, const Eigen::Isometry3d& seed, FrameTimings&) override {
    seeds.push_back(seed);
    const bool in_basin = test::angle_between(seed.linear(), truth.linear()) < 10 * test::kDeg &&
                          (seed.translation() - truth.translation()).norm() < 0.15;
    Placement p;
    p.T_world_camera = in_basin ? truth : seed;
    IcpQuality& q = p.icp.quality;
    q.iterations = 5;
    q.converged = true;
    q.inliers = 5000;
    q.inlier_fraction = q.pixel_fraction = in_basin ? 0.9 : 0.1;
    q.condition = in_basin ? basin_condition : 100;
    q.translation_condition = in_basin ? basin_translation_condition : 10;
    q.residual_per_weight = 1e-6;
    p.icp.verdict = in_basin && q.condition <= IcpReliabilityThresholds{}.max_condition
                        ? IcpVerdict::kReliable
                        : IcpVerdict::kUnreliable;
    return p;
  }
  IcpReliabilityThresholds reliability(const DepthView&) const override { return {}; }
  // The room's surface along a grid of rays within 25 deg of the true camera's axis.
  Result<FramePoints> frame_points(int) override {
    FramePoints out;
    const Eigen::Vector3d c = truth.translation();
    for (int i = -10; i <= 10; ++i)
      for (int j = -10; j <= 10; ++j) {
        const Eigen::Vector3d ray_camera =
            Eigen::Vector3d(std::tan(2.5 * i * test::kDeg), std::tan(2.5 * j * test::kDeg), 1)
                .normalized();
        const Eigen::Vector3d d = truth.linear() * ray_camera;
        double t = std::numeric_limits<double>::infinity();
        const Eigen::Vector3d lo(0, 0, 0), hi(2.4, 1.6, 1.2);
        for (int a = 0; a < 3; ++a) {
          if (d[a] > 1e-9) t = std::min(t, (hi[a] - c[a]) / d[a]);
          if (d[a] < -1e-9) t = std::min(t, (lo[a] - c[a]) / d[a]);
        }
        out.points.push_back(t * ray_camera);
      }
    return out;
  }
  Result<HostVolume> model_snapshot() const override { return volume_; }

 private:
  HostVolume volume_;
};

// The same room, where once per search the first candidate ICP does not place is placed 0.6 m
// from the true pose instead, with the quality `alias` gives it.
class AliasedRoomModel : public TurnedRoomModel {
 public:
  struct Alias {
    bool reliable = true;
    double fraction = 0.9;  // the inlier and pixel fractions
    double condition = 100;
    double residual_per_weight = 1e-6;  // m^2
  };
  explicit AliasedRoomModel(const Alias& alias) : alias_(alias) {}

  Result<Placement> place(const DepthView& depth, const Eigen::Isometry3d& seed,
                          FrameTimings& timings) override {
    auto p = TurnedRoomModel::place(depth, seed, timings);
    if (p && !p->icp.reliable() && !alias_placed_) {
      alias_placed_ = true;
      p->T_world_camera.translation() = truth.translation() + Eigen::Vector3d(0.6, 0, 0);
      if (alias_.reliable) p->icp.verdict = IcpVerdict::kReliable;
      p->icp.quality.inlier_fraction = p->icp.quality.pixel_fraction = alias_.fraction;
      p->icp.quality.condition = alias_.condition;
      p->icp.quality.residual_per_weight = alias_.residual_per_weight;
    }
    return p;
  }
  Result<FramePoints> frame_points(int level) override {
    alias_placed_ = false;  // each search meets the alias once
    return TurnedRoomModel::frame_points(level);
  }

 private:
  Alias alias_;
  bool alias_placed_ = false;
};

// An upright camera (y down, z up in the world) at `position`, looking `yaw_deg` from +x.
Eigen::Isometry3d upright_camera(const Eigen::Vector3d& position, double yaw_deg) {
  const double yaw = yaw_deg * test::kDeg;
  const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0), down(0, 0, -1);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = down.cross(forward);
  T.linear().col(1) = down;
  T.linear().col(2) = forward;
  T.translation() = position;
  return T;
}

// The frame lost `k` frames without a gyroscope (`fps` frames a second), at the estimate
// `T_estimate` (where the scan was lost a second before frame 0); the search's outcome.
std::optional<ModelAligner::Placement> lost_without_gyro(RelocalizationDriver& driver,
                                                         ModelAligner& model, int k,
                                                         const Eigen::Isometry3d& T_estimate,
                                                         double fps = 30) {
  RelocalizationDriver::Frame f;
  f.timestamp = k / fps;
  f.constrained_time = -1.0;
  f.lost = true;
  f.rotation_from_imu = false;
  f.T_world_estimate = T_estimate;
  f.lost_at = T_estimate.translation();
  FrameTimings timings;
  auto out = driver.on_frame(f, DepthView{}, model, timings);
  EXPECT_TRUE(out.ok());
  return out.ok() ? out->found : std::nullopt;
}

// The scan lost facing +x at (0.8, 0.6, 0.6), the camera since turned 140 deg and moved 0.5 m
// (it faces the corner of the walls x = 0 and y = 1.6): lost frames 1 to `frames` search without
// a gyroscope, and none ends the loss.
void expect_never_placed(TurnedRoomModel& model, int frames) {
  const Eigen::Isometry3d lost_at = upright_camera(Eigen::Vector3d(0.8, 0.6, 0.6), 0);
  model.truth = upright_camera(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
  RelocalizationDriver driver{ReconstructorConfig{}};
  for (int k = 1; k <= frames; ++k)
    EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at)) << "lost frame " << k;
  EXPECT_FALSE(model.seeds.empty());
}

// The same loss with `config`: the regular search finds the only fit, and the next lost frame's
// search confirms it at the true pose.
void expect_placed_at_confirmation(TurnedRoomModel& model, const ReconstructorConfig& config) {
  const Eigen::Isometry3d lost_at = upright_camera(Eigen::Vector3d(0.8, 0.6, 0.6), 0);
  model.truth = upright_camera(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
  RelocalizationDriver driver(config);
  const int n = config.relocalization.interval;
  for (int k = 1; k <= n; ++k) EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at));
  const auto found = lost_without_gyro(driver, model, n + 1, lost_at);
  ASSERT_TRUE(found);
  EXPECT_LT((found->T_world_camera.translation() - model.truth.translation()).norm(), 1e-9);
}

TEST(RelocalizationWithoutGyro, TheSearchFindsAFrameThatTurnedAndMovedWhileLost) {
  TurnedRoomModel model;
  // Lost facing +x at (0.8, 0.6, 0.6); the camera turned 140 deg and moved 0.5 m since, and
  // faces the corner of the walls x = 0 and y = 1.6.
  const Eigen::Isometry3d lost_at = upright_camera(Eigen::Vector3d(0.8, 0.6, 0.6), 0);
  model.truth = upright_camera(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
  ReconstructorConfig config;
  RelocalizationDriver driver(config);
  for (int k = 1; k <= config.relocalization.interval; ++k)
    EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at));
  // The first search's only fit waits for the next lost frame's search to find it again.
  EXPECT_FALSE(model.seeds.empty());
  const std::optional<ModelAligner::Placement> found =
      lost_without_gyro(driver, model, config.relocalization.interval + 1, lost_at);
  ASSERT_TRUE(found);
  EXPECT_LT((found->T_world_camera.translation() - model.truth.translation()).norm(), 1e-9);
  EXPECT_LT(test::angle_between(found->T_world_camera.linear(), model.truth.linear()), 1e-9);
  // The best candidate, tried first, is within ICP's basin: the sweep's nearest orientation
  // (15 deg steps, 5 deg off) and its translation refined on the fine field.
  ASSERT_FALSE(model.seeds.empty());
  EXPECT_LT(test::angle_between(model.seeds.front().linear(), model.truth.linear()),
            7.5 * test::kDeg);
  EXPECT_LT((model.seeds.front().translation() - model.truth.translation()).norm(), 0.15);
}

TEST(RelocalizationWithoutGyro, AFitThatFixesOnlyThePositionDoesNotPlaceTheFrame) {
  // Without the gyroscope the search finds the orientation too: a fit whose rotation the depth
  // leaves weak (kappa 1e4) is not taken for its well-conditioned translation (kappa 20).
  TurnedRoomModel model;
  model.basin_condition = 1e4;
  model.basin_translation_condition = 20;
  expect_never_placed(model, 3 * ReconstructorConfig{}.relocalization.interval);
}

TEST(RelocalizationWithoutGyro, AFitThatOnlyJustFixesEveryDirectionDoesNotPlaceTheFrame) {
  // kappa 400 passes the tracking gate (562.3) but not half of it
  // (relocalization.turned_condition_factor, 0.5): without the gyroscope such a fit may be
  // coincidental structure far from the camera.
  const ReconstructorConfig defaults;
  ASSERT_NEAR(defaults.relocalization.turned_condition_factor, 0.5, 1e-12);
  TurnedRoomModel model;
  model.basin_condition = 400;
  expect_never_placed(model, 3 * defaults.relocalization.interval);
  // With the factor at 1 the same fit ends the loss at the confirming search; kappa 250, within
  // half the gate, ends it with the default.
  for (const auto& [factor, condition] : {std::pair{1.0, 400.0}, std::pair{0.5, 250.0}}) {
    SCOPED_TRACE("factor " + std::to_string(factor) + ", kappa " + std::to_string(condition));
    ReconstructorConfig config;
    config.relocalization.turned_condition_factor = factor;
    TurnedRoomModel placed_model;
    placed_model.basin_condition = condition;
    expect_placed_at_confirmation(placed_model, config);
  }
}

TEST(RelocalizationWithoutGyro, TheConfirmationAllowsForWhatTheCameraMovesBetweenTheFrames) {
  // The camera moves 0.2 m between the lost frame whose search finds the only fit and the next
  // one, while the estimate stays where the scan was lost.
  const Eigen::Isometry3d lost_at = upright_camera(Eigen::Vector3d(0.8, 0.6, 0.6), 0);
  const Eigen::Isometry3d first = upright_camera(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
  const Eigen::Isometry3d moved = upright_camera(Eigen::Vector3d(1.2, 0.7, 0.6), 140);
  const ReconstructorConfig config;
  const int n = config.relocalization.interval;
  {
    // 4 frames a second: 0.2 m in 0.25 s is within a hand-held camera's 2 m/s, and confirms.
    TurnedRoomModel model;
    RelocalizationDriver driver(config);
    model.truth = first;
    for (int k = 1; k <= n; ++k) EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at, 4));
    model.truth = moved;
    const auto found = lost_without_gyro(driver, model, n + 1, lost_at, 4);
    ASSERT_TRUE(found);
    EXPECT_LT((found->T_world_camera.translation() - moved.translation()).norm(), 1e-9);
  }
  {
    // 30 frames a second: 0.2 m in a frame is beyond it. The next lost frame searches again
    // and confirms the second fit where the camera stays.
    TurnedRoomModel model;
    RelocalizationDriver driver(config);
    model.truth = first;
    for (int k = 1; k <= n; ++k) EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at));
    model.truth = moved;
    EXPECT_FALSE(lost_without_gyro(driver, model, n + 1, lost_at));
    const auto found = lost_without_gyro(driver, model, n + 2, lost_at);
    ASSERT_TRUE(found);
    EXPECT_LT((found->T_world_camera.translation() - moved.translation()).norm(), 1e-9);
  }
}

TEST(RelocalizationWithoutGyro, AFitElsewhereRejectsTheBestOne) {
  // ICP also settles, reliably, at a place 0.6 m away (a like-looking corner): nothing is taken,
  // however often the frame searches.
  AliasedRoomModel model({});
  expect_never_placed(model, 4 * ReconstructorConfig{}.relocalization.interval);
}

TEST(RelocalizationWithoutGyro, AFitElsewhereThatExplainsTheFrameWorseRejectsNothing) {
  // The place 0.6 m away fits but for the condition number, its residual per weight 30 times
  // the true place's (a wall the view shares, its other points far off): the true place is
  // the only fit, and the next search confirms it.
  AliasedRoomModel model(
      {.reliable = false, .fraction = 0.7, .condition = 3000, .residual_per_weight = 30e-6});
  const Eigen::Isometry3d lost_at = upright_camera(Eigen::Vector3d(0.8, 0.6, 0.6), 0);
  model.truth = upright_camera(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
  ReconstructorConfig config;
  RelocalizationDriver driver(config);
  for (int k = 1; k <= config.relocalization.interval; ++k)
    EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at));
  const std::optional<ModelAligner::Placement> found =
      lost_without_gyro(driver, model, config.relocalization.interval + 1, lost_at);
  ASSERT_TRUE(found);
  EXPECT_LT((found->T_world_camera.translation() - model.truth.translation()).norm(), 1e-9);
  // Every fit elsewhere a rival, as before the ratio: nothing is taken.
  config.relocalization.rival_residual_ratio = 0;
  RelocalizationDriver strict(config);
  for (int k = 1; k <= 4 * config.relocalization.interval; ++k)
    EXPECT_FALSE(lost_without_gyro(strict, model, k, lost_at));
}

TEST(RelocalizationWithoutGyro, TheSearchTakesTheOrientationsTheModelWasScannedFrom) {
  // Lost upright; the camera comes back pitched 35 deg down and rolled 8 deg, beyond the sweep's
  // one step of tilt and ICP's basin, but close to a frame that was fused.
  const auto pitched = [](const Eigen::Vector3d& position, double yaw_deg) {
    Eigen::Isometry3d T = upright_camera(position, yaw_deg);
    T.linear() = T.linear() * Eigen::AngleAxisd(-35 * test::kDeg, Eigen::Vector3d::UnitX()) *
                 Eigen::AngleAxisd(8 * test::kDeg, Eigen::Vector3d::UnitZ());
    return T;
  };
  const Eigen::Isometry3d lost_at = upright_camera(Eigen::Vector3d(0.8, 0.6, 0.6), 0);
  ReconstructorConfig config;
  const int searches = 3 * config.relocalization.interval;
  {
    TurnedRoomModel model;
    model.truth = pitched(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
    RelocalizationDriver driver(config);
    driver.note_view(lost_at.linear());
    for (int k = 1; k <= searches; ++k) EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at));
    EXPECT_FALSE(model.seeds.empty());
  }
  TurnedRoomModel model;
  model.truth = pitched(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
  RelocalizationDriver driver(config);
  driver.note_view(lost_at.linear());
  driver.note_view(pitched(Eigen::Vector3d(1.0, 1.0, 0.6), 144).linear());  // 4 deg off
  std::optional<ModelAligner::Placement> found;
  for (int k = 1; k <= searches && !found; ++k)
    found = lost_without_gyro(driver, model, k, lost_at);
  ASSERT_TRUE(found);
  EXPECT_LT((found->T_world_camera.translation() - model.truth.translation()).norm(), 1e-9);
  EXPECT_LT(test::angle_between(found->T_world_camera.linear(), model.truth.linear()), 1e-9);
}

TEST(RelocalizationWithoutGyro, NoSearchWithoutTheGyroWhenTheSweepIsOff) {
  TurnedRoomModel model;
  const Eigen::Isometry3d lost_at = upright_camera(Eigen::Vector3d(0.8, 0.6, 0.6), 0);
  model.truth = upright_camera(Eigen::Vector3d(1.2, 0.9, 0.6), 140);
  ReconstructorConfig config;
  config.relocalization.turn_step_deg = 0;
  RelocalizationDriver driver(config);
  for (int k = 1; k <= 3 * config.relocalization.interval; ++k)
    EXPECT_FALSE(lost_without_gyro(driver, model, k, lost_at));
  EXPECT_TRUE(model.seeds.empty());
}

}  // namespace
}  // namespace imufusion
