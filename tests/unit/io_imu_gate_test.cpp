// The IMU sample gate shared by imu.txt and the UDP stream: rates and forces beyond a real
// sensor, samples out of order, and jumps in time that the samples after them do not confirm
// are rejected and counted; a real gap, confirmed, is accepted.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "io/imu_gate.hpp"

namespace imufusion {
namespace {

using io::ImuGate;
using io::ImuVerdict;

ReceivedImuSample at(double t, double wx = 0.1, double az = 9.81) {
  ReceivedImuSample r;
  r.sample.timestamp = t;
  r.sample.gyro = Eigen::Vector3d(wx, 0.0, 0.0);
  r.sample.accel = Eigen::Vector3d(0.0, 0.0, az);
  r.host_receive_time = t + 100.0;
  return r;
}

// Pushes a 200 Hz stream from t0 (n samples); returns what was released.
std::vector<double> push_stream(ImuGate& gate, double t0, int n) {
  std::vector<ReceivedImuSample> released;
  for (int i = 0; i < n; ++i) gate.push(at(t0 + 0.005 * i), &released);
  std::vector<double> stamps;
  for (const auto& r : released) stamps.push_back(r.sample.timestamp);
  return stamps;
}

TEST(ImuGate, RejectsRatesAndForcesNoRealImuMeasures) {
  ImuGate gate(ImuSampleLimits{});
  std::vector<ReceivedImuSample> released;
  push_stream(gate, 0.0, 5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(gate.push(at(0.1, 1e300), &released), ImuVerdict::kImplausible);
  EXPECT_EQ(gate.push(at(0.105, 1000.0), &released), ImuVerdict::kImplausible);
  EXPECT_EQ(gate.push(at(0.11, -36.0), &released), ImuVerdict::kImplausible);
  EXPECT_EQ(gate.push(at(0.115, 0.1, 1e6), &released), ImuVerdict::kImplausible);
  EXPECT_EQ(gate.push(at(0.12, nan), &released), ImuVerdict::kImplausible);
  EXPECT_EQ(gate.push(at(nan), &released), ImuVerdict::kImplausible);
  EXPECT_EQ(gate.implausible(), 6u);
  // At the limits (34 rad/s, 15 g) a sample is a measurement.
  released.clear();
  EXPECT_EQ(gate.push(at(0.125, 34.0, 15 * 9.81), &released), ImuVerdict::kAccepted);
  ASSERT_EQ(released.size(), 1u);
  EXPECT_EQ(released.front().host_receive_time, 100.125);
}

TEST(ImuGate, AStreamStartsOnceConfirmed) {
  ImuGate gate(ImuSampleLimits{});
  std::vector<ReceivedImuSample> released;
  for (int i = 0; i < 3; ++i) EXPECT_EQ(gate.push(at(0.005 * i), &released), ImuVerdict::kHeld);
  EXPECT_TRUE(released.empty());
  EXPECT_EQ(gate.push(at(0.015), &released), ImuVerdict::kAccepted);
  ASSERT_EQ(released.size(), 4u);
  EXPECT_EQ(released.front().sample.timestamp, 0.0);
  EXPECT_EQ(released.back().sample.timestamp, 0.015);
}

TEST(ImuGate, OneLineFarInTheFutureIsAJumpAndTheStreamGoesOn) {
  ImuGate gate(ImuSampleLimits{});
  std::vector<ReceivedImuSample> released;
  for (int i = 0; i < 10; ++i) gate.push(at(0.005 * i), &released);
  EXPECT_EQ(gate.push(at(1e6), &released), ImuVerdict::kHeld);
  for (int i = 10; i < 20; ++i)
    EXPECT_EQ(gate.push(at(0.005 * i), &released), ImuVerdict::kAccepted);
  EXPECT_EQ(gate.time_jumps(), 1u);
  ASSERT_EQ(released.size(), 20u);
  for (std::size_t i = 1; i < released.size(); ++i) {
    EXPECT_GT(released[i].sample.timestamp, released[i - 1].sample.timestamp);
    EXPECT_LT(released[i].sample.timestamp, 1.0);
  }
}

TEST(ImuGate, AnOutlierBeforeTheStreamStartsIsAJumpToo) {
  ImuGate gate(ImuSampleLimits{});
  std::vector<ReceivedImuSample> released;
  gate.push(at(1e6), &released);
  const std::vector<double> stamps = push_stream(gate, 5.0, 10);
  EXPECT_EQ(gate.time_jumps(), 1u);
  ASSERT_EQ(stamps.size() + released.size(), 10u);
}

TEST(ImuGate, AGapThatTheSamplesAfterItConfirmIsAccepted) {
  ImuGate gate(ImuSampleLimits{});
  std::vector<double> stamps = push_stream(gate, 0.0, 10);
  const std::vector<double> after = push_stream(gate, 30.0, 10);  // 30 s without samples
  EXPECT_EQ(gate.time_jumps(), 0u);
  EXPECT_EQ(stamps.size() + after.size(), 20u);  // each start waits for 3 samples, then all go
  ASSERT_FALSE(after.empty());
  EXPECT_EQ(after.front(), 30.0);
}

TEST(ImuGate, SamplesOutOfOrderAreRejected) {
  ImuGate gate(ImuSampleLimits{});
  std::vector<ReceivedImuSample> released;
  push_stream(gate, 0.0, 10);
  EXPECT_EQ(gate.push(at(0.02), &released), ImuVerdict::kOutOfOrder);
  EXPECT_EQ(gate.push(at(0.045), &released), ImuVerdict::kOutOfOrder);  // a duplicate
  EXPECT_EQ(gate.push(at(-1e6), &released), ImuVerdict::kOutOfOrder);
  EXPECT_EQ(gate.push(at(0.05), &released), ImuVerdict::kAccepted);
  // Among the samples of a stream not yet confirmed.
  ImuGate start(ImuSampleLimits{});
  start.push(at(1.0), &released);
  start.push(at(1.1), &released);
  EXPECT_EQ(start.push(at(1.05), &released), ImuVerdict::kOutOfOrder);
  EXPECT_EQ(start.latest(), 1.1);
}

TEST(ImuGate, FinishReleasesAShortStreamAndRejectsAnUnconfirmedJump) {
  ImuGate short_stream(ImuSampleLimits{});
  std::vector<ReceivedImuSample> released;
  short_stream.push(at(1.0), &released);
  short_stream.push(at(1.01), &released);
  short_stream.finish(&released);
  EXPECT_EQ(released.size(), 2u);

  ImuGate jump(ImuSampleLimits{});
  released.clear();
  for (int i = 0; i < 10; ++i) jump.push(at(0.005 * i), &released);
  jump.push(at(500.0), &released);
  jump.finish(&released);
  EXPECT_EQ(released.size(), 10u);
  EXPECT_EQ(jump.time_jumps(), 1u);
}

}  // namespace
}  // namespace imufusion
