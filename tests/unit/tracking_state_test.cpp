#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "imufusion/tracking.hpp"

using namespace imufusion;

namespace {

void expect(const TrackingDecision& d, TrackingStatus status, PoseSource source, bool fuse) {
  EXPECT_EQ(d.status, status) << to_string(d.status);
  EXPECT_EQ(d.source, source) << to_string(d.source);
  EXPECT_EQ(d.fuse, fuse);
}

TrackingStateMachine lost_machine(int recovery_frames, int relocalized_recovery_frames = 1) {
  TrackingStateMachine m(
      TrackingConfig{.recovery_frames = recovery_frames,
                     .relocalized_recovery_frames = relocalized_recovery_frames});
  m.start();
  m.step(false, false);
  return m;
}

}  // namespace

TEST(TrackingStateMachine, FirstFrameDefinesTheWorldAndIsFused) {
  TrackingStateMachine m;
  EXPECT_FALSE(m.started());
  expect(m.start(), TrackingStatus::kTracking, PoseSource::kInitial, true);
  EXPECT_TRUE(m.started());
  EXPECT_FALSE(m.recovering_or_lost());
}

TEST(TrackingStateMachine, StepBeforeStartActsAsStart) {
  TrackingStateMachine m;
  expect(m.step(false, false), TrackingStatus::kTracking, PoseSource::kInitial, true);
}

TEST(TrackingStateMachine, TrackingStaysTrackingOnReliableIcp) {
  TrackingStateMachine m;
  m.start();
  // Convergence does not matter while tracking: a one-iteration IMU-seeded ICP rarely "converges".
  expect(m.step(true, false), TrackingStatus::kTracking, PoseSource::kIcp, true);
  expect(m.step(true, true), TrackingStatus::kTracking, PoseSource::kIcp, true);
}

TEST(TrackingStateMachine, UnreliableIcpLosesTrackingAndStopsFusion) {
  TrackingStateMachine m;
  m.start();
  expect(m.step(false, true), TrackingStatus::kLost, PoseSource::kDeadReckoning, false);
  EXPECT_TRUE(m.recovering_or_lost());
  expect(m.step(false, false), TrackingStatus::kLost, PoseSource::kDeadReckoning, false);
}

TEST(TrackingStateMachine, RecoveryNeedsConsecutiveReliableConvergedFrames) {
  auto m = lost_machine(3);
  auto d1 = m.step(true, true);
  expect(d1, TrackingStatus::kRecovering, PoseSource::kIcp, false);
  EXPECT_EQ(d1.good_frames, 1);
  auto d2 = m.step(true, true);
  expect(d2, TrackingStatus::kRecovering, PoseSource::kIcp, false);
  EXPECT_EQ(d2.good_frames, 2);
  EXPECT_FALSE(d2.recovered);
  auto d3 = m.step(true, true);
  expect(d3, TrackingStatus::kTracking, PoseSource::kIcp, true);
  EXPECT_TRUE(d3.recovered);
  EXPECT_FALSE(m.recovering_or_lost());
  EXPECT_FALSE(m.step(true, true).recovered);
}

TEST(TrackingStateMachine, AFrameTheSearchRelocalizedEndsTheLossAtOnce) {
  auto m = lost_machine(3);
  auto d = m.step(true, true, false, true, /*relocalized=*/true);
  expect(d, TrackingStatus::kTracking, PoseSource::kIcp, true);
  EXPECT_TRUE(d.recovered);
  EXPECT_FALSE(m.recovering_or_lost());
}

TEST(TrackingStateMachine, RelocalizedRecoveryFramesCountTheRestAfterTheSearch) {
  auto m = lost_machine(4, 2);
  auto d1 = m.step(true, true, false, true, /*relocalized=*/true);
  expect(d1, TrackingStatus::kRecovering, PoseSource::kIcp, false);
  EXPECT_EQ(d1.good_frames, 3);
  auto d2 = m.step(true, true);
  expect(d2, TrackingStatus::kTracking, PoseSource::kIcp, true);
  EXPECT_TRUE(d2.recovered);
  // Counted as any other frame once recovering, and nothing while it has not settled.
  auto r = lost_machine(3);
  expect(r.step(true, false, false, true, true), TrackingStatus::kLost, PoseSource::kDeadReckoning,
         false);
  EXPECT_EQ(r.step(true, true).good_frames, 1);
  auto d3 = r.step(true, true, false, true, true);
  expect(d3, TrackingStatus::kRecovering, PoseSource::kIcp, false);
  EXPECT_EQ(d3.good_frames, 2);
}

TEST(TrackingStateMachine, ReliableButUnconvergedDoesNotCountWhileLost) {
  auto m = lost_machine(2);
  expect(m.step(true, false), TrackingStatus::kLost, PoseSource::kDeadReckoning, false);
  expect(m.step(true, true), TrackingStatus::kRecovering, PoseSource::kIcp, false);
}

TEST(TrackingStateMachine, SetbackDuringRecoveryStartsTheCountAgain) {
  auto m = lost_machine(3);
  m.step(true, true);
  m.step(true, true);
  expect(m.step(false, true), TrackingStatus::kLost, PoseSource::kDeadReckoning, false);
  EXPECT_EQ(m.step(true, true).good_frames, 1);
  EXPECT_EQ(m.step(true, true).good_frames, 2);
  expect(m.step(true, true), TrackingStatus::kTracking, PoseSource::kIcp, true);
}

TEST(TrackingStateMachine, RecoveringReliableButUnconvergedHoldsTheCount) {
  auto m = lost_machine(3);
  m.step(true, true);
  auto held = m.step(true, false);
  expect(held, TrackingStatus::kRecovering, PoseSource::kIcp, false);
  EXPECT_EQ(held.good_frames, 1);
  EXPECT_EQ(m.step(true, true).good_frames, 2);
  expect(m.step(true, true), TrackingStatus::kTracking, PoseSource::kIcp, true);
}

TEST(TrackingStateMachine, ADisagreeingRecoveringFrameStartsTheCountAgainFromItself) {
  auto m = lost_machine(3);
  m.step(true, true);
  EXPECT_EQ(m.step(true, true).good_frames, 2);
  m.restart_recovery();
  auto restarted = m.step(true, true);
  expect(restarted, TrackingStatus::kRecovering, PoseSource::kIcp, false);
  EXPECT_EQ(restarted.good_frames, 1);
  EXPECT_FALSE(restarted.recovered);
  EXPECT_EQ(m.step(true, true).good_frames, 2);
  auto d = m.step(true, true);
  expect(d, TrackingStatus::kTracking, PoseSource::kIcp, true);
  EXPECT_TRUE(d.recovered);
}

TEST(TrackingStateMachine, RestartingTheRecoveryChangesNothingWhileTrackingOrLost) {
  TrackingStateMachine tracking({3, 10});
  tracking.start();
  tracking.restart_recovery();
  expect(tracking.step(true, true), TrackingStatus::kTracking, PoseSource::kIcp, true);
  auto lost = lost_machine(1);
  lost.restart_recovery();
  auto d = lost.step(true, true);
  expect(d, TrackingStatus::kTracking, PoseSource::kIcp, true);
  EXPECT_TRUE(d.recovered);
}

TEST(TrackingStateMachine, RecoveringUnreliableFallsBackToLost) {
  auto m = lost_machine(3);
  m.step(true, true);
  expect(m.step(false, true), TrackingStatus::kLost, PoseSource::kDeadReckoning, false);
}

TEST(TrackingStateMachine, OneRecoveryFrameResumesFusionAtOnce) {
  auto m = lost_machine(1);
  auto d = m.step(true, true);
  expect(d, TrackingStatus::kTracking, PoseSource::kIcp, true);
  EXPECT_TRUE(d.recovered);
}

TEST(TrackingStateMachine, ResetForgetsEverything) {
  auto m = lost_machine(3);
  m.step(true, true);
  m.reset();
  EXPECT_FALSE(m.started());
  expect(m.step(true, true), TrackingStatus::kTracking, PoseSource::kInitial, true);
}

TEST(TrackingStateMachine, NamesRoundTrip) {
  for (auto s : {TrackingStatus::kTracking, TrackingStatus::kLost, TrackingStatus::kRecovering})
    EXPECT_EQ(parse_tracking_status(to_string(s)), s);
  for (auto s : {PoseSource::kInitial, PoseSource::kIcp, PoseSource::kIcpPartial,
                 PoseSource::kDeadReckoning, PoseSource::kKnown})
    EXPECT_EQ(parse_pose_source(to_string(s)), s);
  EXPECT_EQ(std::string(to_string(PoseSource::kIcpPartial)), "icp_partial");
  EXPECT_FALSE(parse_tracking_status("tracked").has_value());
  EXPECT_FALSE(parse_pose_source("imu").has_value());
}

TEST(TrackingStateMachine, PartialIcpKeepsTrackingAndFusesWithItsOwnPoseSource) {
  TrackingStateMachine m;
  m.start();
  expect(m.step(false, false, true), TrackingStatus::kTracking, PoseSource::kIcpPartial, true);
  EXPECT_FALSE(m.recovering_or_lost());
  expect(m.step(true, false), TrackingStatus::kTracking, PoseSource::kIcp, true);
  // A reliable verdict wins over the partial flag.
  expect(m.step(true, false, true), TrackingStatus::kTracking, PoseSource::kIcp, true);
}

TEST(TrackingStateMachine, PartialIcpBeyondItsFusionBudgetIsLostButKeepsItsPose) {
  TrackingStateMachine m;
  m.start();
  expect(m.step(false, false, true, false), TrackingStatus::kLost, PoseSource::kIcpPartial, false);
  EXPECT_TRUE(m.recovering_or_lost());
}

TEST(TrackingStateMachine, PartialIcpNeitherRecoversNorCountsWhileLost) {
  auto m = lost_machine(2);
  // The partial pose beats dead reckoning, but is not fused and does not count.
  expect(m.step(false, true, true), TrackingStatus::kLost, PoseSource::kIcpPartial, false);
  expect(m.step(false, true, false), TrackingStatus::kLost, PoseSource::kDeadReckoning, false);
  expect(m.step(true, true), TrackingStatus::kRecovering, PoseSource::kIcp, false);
  // While recovering, a partial alignment breaks the count like any unreliable one.
  expect(m.step(false, true, true), TrackingStatus::kLost, PoseSource::kIcpPartial, false);
  expect(m.step(true, true), TrackingStatus::kRecovering, PoseSource::kIcp, false);
  expect(m.step(true, true), TrackingStatus::kTracking, PoseSource::kIcp, true);
}

TEST(PairingReference, LowersThePairingTestsToWhatAlignedFramesPair) {
  TrackingConfig config;
  config.pairing_window = 3;
  config.pairing_ratio = 0.5;
  config.pairing_floor = 0.1;
  PairingReference reference(config);
  double inlier = 0.4, pixel = 0.35;
  reference.apply(inlier, pixel);  // nothing seen yet: the absolute thresholds
  EXPECT_EQ(inlier, 0.4);
  EXPECT_EQ(pixel, 0.35);
  for (double f : {0.30, 0.26, 0.28}) reference.add(f, f - 0.05);
  inlier = 0.4, pixel = 0.35;
  reference.apply(inlier, pixel);
  EXPECT_DOUBLE_EQ(inlier, 0.5 * 0.28);  // half the median
  EXPECT_DOUBLE_EQ(pixel, 0.5 * 0.23);
  reference.add(0.9, 0.9);  // a clean sensor: never stricter than the absolute thresholds
  reference.add(0.9, 0.9);
  inlier = 0.4, pixel = 0.35;
  reference.apply(inlier, pixel);
  EXPECT_EQ(inlier, 0.4);
  EXPECT_EQ(pixel, 0.35);
  for (int i = 0; i < 3; ++i) reference.add(0.05, 0.05);  // the window forgets; the floor holds
  inlier = 0.4, pixel = 0.35;
  reference.apply(inlier, pixel);
  EXPECT_EQ(inlier, 0.1);
  EXPECT_EQ(pixel, 0.1);
  EXPECT_EQ(reference.size(), 3u);
  reference.reset();
  EXPECT_EQ(reference.size(), 0u);
}

TEST(PairingReference, NarrowsTheResidualTestToTheNoiseAlignedFramesShow) {
  TrackingConfig config;
  config.pairing_window = 3;
  config.residual_ratio = 3;
  PairingReference reference(config);
  const double fixed = 4e-5, widened = 4e-4, noise = 2e-4;  // m^2
  // Nothing seen yet: the limit widened to the noise model.
  EXPECT_EQ(reference.residual_limit(fixed, widened, noise), widened);
  // Aligned frames that leave a twentieth of the model's noise variance: three times that.
  for (double r : {1.0e-5, 0.8e-5, 1.2e-5}) reference.add_residual(r, noise);
  EXPECT_DOUBLE_EQ(reference.residual_limit(fixed, widened, 2 * noise), 3 * 0.05 * 2 * noise);
  // Never below the fixed limit (a near, clean frame), never above the widened one.
  EXPECT_EQ(reference.residual_limit(fixed, widened, noise / 10), fixed);
  for (int i = 0; i < 3; ++i) reference.add_residual(2 * noise, noise);  // the window forgets
  EXPECT_EQ(reference.residual_limit(fixed, widened, noise), widened);
  // Frames without a residual or a noise estimate teach nothing.
  reference.add_residual(0, noise);
  reference.add_residual(1e-5, 0);
  reference.add_residual(std::numeric_limits<double>::quiet_NaN(), noise);
  EXPECT_EQ(reference.residuals(), 3u);
  reference.reset();
  EXPECT_EQ(reference.residuals(), 0u);
  // Off: the widened limit whatever the frames showed.
  config.residual_ratio = 0;
  PairingReference off(config);
  off.add_residual(1e-5, noise);
  EXPECT_EQ(off.residual_limit(fixed, widened, noise), widened);
}

TEST(PredictionCalibration, ScalesThePredictionsSigmasByHowFarItIsOff) {
  TrackingConfig config;
  config.prediction_window = 3;
  PredictionCalibration calibration(config);
  EXPECT_EQ(calibration.scale(), 1.0);  // nothing seen yet
  for (double chi2 : {2.0, 4.0, 3.0}) calibration.add(chi2);
  EXPECT_EQ(calibration.scale(), 1.0);  // within its sigmas: never below 1
  // A prediction 4 times further off than its sigmas say: chi^2 16 times its median.
  for (int i = 0; i < 3; ++i) calibration.add(16 * 5.348);
  EXPECT_NEAR(calibration.scale(), 4.0, 1e-9);
  // Judged at the scaled sigmas, a frame as far off has chi^2 at the median: the scale holds.
  for (int i = 0; i < 3; ++i) calibration.add(5.348);
  EXPECT_NEAR(calibration.scale(), 4.0, 1e-9);
  calibration.add(std::numeric_limits<double>::quiet_NaN());  // ignored
  EXPECT_EQ(calibration.size(), 3u);
  calibration.reset();
  EXPECT_EQ(calibration.scale(), 1.0);
  PredictionCalibration off(TrackingConfig{.prediction_window = 0});
  off.add(100);
  EXPECT_EQ(off.size(), 0u);
}
