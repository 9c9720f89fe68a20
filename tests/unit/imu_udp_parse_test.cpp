#include <gtest/gtest.h>

#include "imufusion/imu_stream.hpp"

namespace imufusion {
namespace {

TEST(ImuLine, ImuTxtLine) {
  ImuSample sample;
  ASSERT_EQ(parse_imu_line("1000.005 0.01 -0.02 0.03 0.1 9.81 -0.2\r", &sample),
            ImuLineKind::kSample);
  EXPECT_EQ(sample.timestamp, 1000.005);
  EXPECT_EQ(sample.gyro, Eigen::Vector3d(0.01, -0.02, 0.03));
  EXPECT_EQ(sample.accel, Eigen::Vector3d(0.1, 9.81, -0.2));
}

TEST(ImuLine, SensorstreamWithMagnetometerAndExtras) {
  // As the app formats it: "%.5f" stamp, ", %d, %.3f,%.3f,%.3f" per sensor.
  ImuSample sample;
  ASSERT_EQ(parse_imu_line("12345.67891, 3, 0.123,9.801,-0.456, 4, 0.010,-0.020,0.300, 5, "
                           "12.500,-3.250,40.000, 84, 0.1,0.2,0.3, 86,0.9,0.1,0.2,0.3, 88, 31",
                           &sample),
            ImuLineKind::kSample);
  EXPECT_EQ(sample.timestamp, 12345.67891);
  EXPECT_EQ(sample.accel, Eigen::Vector3d(0.123, 9.801, -0.456));
  EXPECT_EQ(sample.gyro, Eigen::Vector3d(0.010, -0.020, 0.300));
}

TEST(ImuLine, SensorstreamWithGpsBeforeTheAccelerometer) {
  ImuSample sample;
  ASSERT_EQ(parse_imu_line("77.5, 1,  52.517632,  13.447430,  83.2, 3, 5.801,-13.746,-28.710, "
                           "4, 11.797, 0.481, -3.857, 8, 1496608842000",
                           &sample),
            ImuLineKind::kSample);
  EXPECT_EQ(sample.gyro, Eigen::Vector3d(11.797, 0.481, -3.857));
}

TEST(ImuLine, SensorstreamWithoutGyroscopeIsIncomplete) {
  ImuSample sample;
  EXPECT_EQ(parse_imu_line("12.0, 3, 0.1,9.8,0.2, 5, 1.0,2.0,3.0", &sample),
            ImuLineKind::kIncomplete);
}

TEST(ImuLine, MalformedLines) {
  ImuSample sample;
  for (const char* line :
       {"1.0 2.0 3.0", "1 2 3 4 5 6 7 8", "1 2 3 nan 5 6 7", "a b c d e f g", "12.0, 3, 0.1,9.8",
        "12.0, 99, 1,2,3", "12.0, 3, 0.1,x,0.2, 4, 1,2,3", "1e999 0 0 0 0 0 0"}) {
    EXPECT_EQ(parse_imu_line(line, &sample), ImuLineKind::kMalformed) << line;
  }
  EXPECT_EQ(parse_imu_line("", &sample), ImuLineKind::kEmpty);
  EXPECT_EQ(parse_imu_line("   \r", &sample), ImuLineKind::kEmpty);
  EXPECT_EQ(parse_imu_line("# timestamp wx wy wz ax ay az", &sample), ImuLineKind::kEmpty);
}

TEST(ImuLine, CommaSeparatedImuTxtLine) {
  ImuSample sample;
  ASSERT_EQ(parse_imu_line("5.5,3,0.5,0.25,1,2,3", &sample), ImuLineKind::kSample);
  EXPECT_EQ(sample.gyro, Eigen::Vector3d(3, 0.5, 0.25));
}

TEST(ImuUdpListener, RefusesABadAddress) {
  ImuUdpOptions options;
  options.address = "localhost:5";
  const auto listener = ImuUdpListener::open(options);
  ASSERT_FALSE(listener.ok());
  EXPECT_EQ(listener.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(listener.error().message.find("localhost:5"), std::string::npos);
}

TEST(ImuUdpListener, ReportsAPortInUse) {
  auto first = ImuUdpListener::open({});
  ASSERT_TRUE(first.ok()) << first.error().describe();
  ImuUdpOptions options;
  options.port = first->port();
  const auto second = ImuUdpListener::open(options);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.error().code, ErrorCode::kIoError);
  EXPECT_NE(second.error().message.find(std::to_string(first->port())), std::string::npos);
}

TEST(ImuUdpListener, ListensOnLoopbackByDefault) {
  auto listener = ImuUdpListener::open({});
  ASSERT_TRUE(listener.ok()) << listener.error().describe();
  EXPECT_EQ(listener->endpoint(), "127.0.0.1:" + std::to_string(listener->port()));
  listener->stop();
  EXPECT_TRUE(listener->take_samples().empty());
}

}  // namespace
}  // namespace imufusion
