#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "imufusion/clock_offset.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

// A synthetic live session: the camera path of a synthetic scene on the host clock, a phone IMU
// whose clock is `offset` behind it (t_host = t_imu + offset), samples that arrive after a
// Wi-Fi-like latency (3 ms plus an exponential tail of mean 10 ms), and ICP rotation rates at
// 30 Hz with Gaussian noise of 0.03 rad/s (about 0.06 degrees per frame).
struct Session {
  std::vector<ImuSample> imu;          // IMU clock
  std::vector<double> arrival;         // host clock
  std::vector<double> frame_times;     // host clock
  std::vector<double> camera_rates;    // rad/s, interval ending at frame_times[k] (k >= 1)
};

Session make_session(synth::SceneKind kind, std::uint64_t seed, double offset, double duration,
                     bool still = false) {
  const double start = 50.0;
  const synth::CameraMotion motion(kind, seed, start);
  synth::ImuConfig config;
  const auto bias = synth::draw_imu_bias(seed);
  Session session;
  std::mt19937_64 rng(seed * 7919 + 17);
  std::exponential_distribution<double> tail(1.0 / 0.010);
  std::normal_distribution<double> icp_noise(0.0, 0.03);
  if (still) {
    for (double t = start; t < start + duration; t += 1.0 / 200.0) {
      ImuSample sample;
      sample.timestamp = t - offset;
      sample.gyro = bias.gyro + Eigen::Vector3d::Constant(0.003 * icp_noise(rng));
      session.imu.push_back(sample);
    }
  } else {
    session.imu = synth::generate_imu(motion, config, bias, start, start + duration, seed);
    for (ImuSample& sample : session.imu) sample.timestamp -= offset;
  }
  for (const ImuSample& sample : session.imu) {
    session.arrival.push_back(sample.timestamp + offset + 0.003 + tail(rng));
  }
  for (double t = start + 0.5; t < start + duration - 0.5; t += 1.0 / 30.0) {
    if (!session.frame_times.empty()) {
      const double previous = session.frame_times.back();
      double rate = 0.0;
      if (!still) {
        const Eigen::Matrix3d R = motion.pose_at(previous).linear().transpose() *
                                  motion.pose_at(t).linear();
        rate = Eigen::AngleAxisd(R).angle() / (t - previous);
      }
      session.camera_rates.push_back(std::abs(rate + icp_noise(rng)));
    }
    session.frame_times.push_back(t);
  }
  return session;
}

ClockOffsetEstimate run(const Session& session, bool with_arrival, double prior = 0.0) {
  ClockOffsetEstimator estimator;
  if (!with_arrival) estimator.set_prior_offset(prior);
  for (std::size_t i = 0; i < session.imu.size(); ++i) {
    if (with_arrival) {
      estimator.add_imu(session.imu[i], session.arrival[i]);
    } else {
      estimator.add_imu(session.imu[i]);
    }
  }
  for (std::size_t k = 1; k < session.frame_times.size(); ++k) {
    estimator.add_camera_rate(session.frame_times[k - 1], session.frame_times[k],
                              session.camera_rates[k - 1]);
  }
  return estimator.estimate();
}

TEST(HostClockMapper, FollowsTheFastestMessageAndADriftingClock) {
  // Sensor clocks drifting 1e-4 s/s either way (a poor crystal), messages 2 ms late plus an
  // exponential tail of mean 20 ms.
  for (const double drift : {-1e-4, 0.0, 1e-4}) {
    HostClockMapper mapper(2e-4);
    EXPECT_FALSE(mapper.offset().has_value());
    std::mt19937_64 rng(3);
    std::exponential_distribution<double> tail(1.0 / 0.02);
    double max_error = 0.0, true_offset = 0.0;
    for (int i = 0; i < 20000; ++i) {
      const double sensor = 10.0 + i * 0.005;
      true_offset = 100.0 + drift * (sensor - 10.0);
      const double host = sensor + true_offset + 0.002 + tail(rng);
      const double mapped = mapper.observe(host, sensor);
      EXPECT_GE(mapped, sensor + true_offset + 0.002 - 1e-9);  // never earlier than possible
      if (i > 200) max_error = std::max(max_error, std::abs(mapped - (sensor + true_offset)));
    }
    // The envelope sits on the smallest latency (2 ms) plus what the tail rarely undercuts
    // within a few samples.
    EXPECT_LT(max_error, 0.006) << "drift " << drift;
    EXPECT_NEAR(*mapper.offset(), true_offset + 0.002, 0.004) << "drift " << drift;
  }
}

TEST(ClockOffsetEstimator, FindsAKnownOffsetOnSyntheticMotion) {
  // 20 s sessions. Tolerances from the worst error over seeds 1-20 per scene (measured: fast
  // 0.79 ms, wall 9.4 ms, room 33.5 ms; rms 0.46, 4.7, 15 ms): the offset is as sharp as the
  // rotation rate varies, so slow walking motion pins it down far less than quick turns.
  struct Case {
    synth::SceneKind kind;
    double tolerance;  // seconds
  };
  for (const Case c : {Case{synth::SceneKind::kFast, 0.002}, Case{synth::SceneKind::kWall, 0.015},
                       Case{synth::SceneKind::kRoom, 0.040}}) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      const double offset = 1234.5 + 0.0371 * static_cast<double>(seed);
      const Session session = make_session(c.kind, seed, offset, 20.0);
      const ClockOffsetEstimate estimate = run(session, true);
      ASSERT_EQ(estimate.source, ClockOffsetEstimate::Source::kCorrelation)
          << synth::to_string(c.kind) << " seed " << seed;
      const double error = estimate.offset - offset;
      std::printf("%s seed %d: error %+.2f ms, correlation %.3f, %zu intervals\n",
                  synth::to_string(c.kind), static_cast<int>(seed), error * 1e3,
                  estimate.correlation, estimate.intervals);
      EXPECT_LT(std::abs(error), c.tolerance) << synth::to_string(c.kind) << " seed " << seed;
      EXPECT_GT(estimate.confidence, 0.5);
      EXPECT_LE(estimate.confidence, 1.0);
      EXPECT_GT(estimate.intervals, 500u);
    }
  }
}

TEST(ClockOffsetEstimator, ArrivalTimesAloneBoundTheOffsetFromAbove) {
  const double offset = -17.25;
  Session session = make_session(synth::SceneKind::kRoom, 4, offset, 20.0);
  session.frame_times.resize(std::min<std::size_t>(session.frame_times.size(), 30));
  session.camera_rates.resize(session.frame_times.size() - 1);
  const ClockOffsetEstimate estimate = run(session, true);
  EXPECT_EQ(estimate.source, ClockOffsetEstimate::Source::kArrival);
  EXPECT_EQ(estimate.confidence, 0.0);
  EXPECT_GE(estimate.offset, offset + 0.003 - 1e-9);  // never below the smallest latency
  EXPECT_LT(estimate.offset, offset + 0.010);
}

TEST(ClockOffsetEstimator, PriorOffsetCentresTheSearchWithoutArrivalTimes) {
  const double offset = 3.125;
  const Session session = make_session(synth::SceneKind::kFast, 2, offset, 20.0);
  const ClockOffsetEstimate estimate = run(session, false, offset + 0.12);
  ASSERT_EQ(estimate.source, ClockOffsetEstimate::Source::kCorrelation);
  EXPECT_NEAR(estimate.offset, offset, 0.003);
}

TEST(ClockOffsetEstimator, AStillCameraGivesNoCorrelationEstimate) {
  const Session session = make_session(synth::SceneKind::kRoom, 5, 2.0, 20.0, true);
  const ClockOffsetEstimate estimate = run(session, true);
  EXPECT_EQ(estimate.source, ClockOffsetEstimate::Source::kArrival);
}

TEST(ClockOffsetEstimator, NothingFedGivesNoEstimate) {
  ClockOffsetEstimator estimator;
  EXPECT_EQ(estimator.estimate().source, ClockOffsetEstimate::Source::kNone);
  estimator.add_camera_rate(1.0, 0.5, 1.0);  // backwards interval: ignored
  estimator.add_camera_rate(1.0, 1.1, std::nan(""));
  EXPECT_EQ(estimator.estimate().source, ClockOffsetEstimate::Source::kNone);
}

}  // namespace
}  // namespace imufusion
