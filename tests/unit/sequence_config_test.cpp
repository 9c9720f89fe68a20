// sequence_config: the preset adjusted by a recorded sequence's calibration, IMU and info.txt, as
// imufusion-scan configures a scan of a sequence.

#include <gtest/gtest.h>

#include <string>

#include "imufusion/presets.hpp"
#include "imufusion/sequence.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

using testing::TempDir;

struct SequenceParts {
  bool calibration = true;
  bool imu_to_camera = true;
  double imu_offset = 0;  // s added to the IMU stamps (another clock: 100 covers no frame)
  std::string gyro_noise_density = "0.005";
};

// Two 16x12 depth frames at t = 1.0 and 1.1 s with what `parts` asks for.
std::filesystem::path write_sequence(const TempDir& dir, const SequenceParts& parts) {
  const auto path = dir / "seq";
  auto writer = SequenceWriter::create(path);
  EXPECT_TRUE(writer.ok());
  for (const double t : {1.0, 1.1})
    EXPECT_TRUE(writer->add_depth(t, testing::make_depth(16, 12, 1)).ok());
  for (int i = 0; i <= 30; ++i) {
    ImuSample s;
    s.timestamp = 0.95 + 0.005 * i + parts.imu_offset;
    s.accel = Eigen::Vector3d(0, 9.81, 0);
    EXPECT_TRUE(writer->add_imu(s).ok());
  }
  if (parts.calibration) {
    EXPECT_TRUE(writer->set_intrinsics({20, 21, 7.5, 5.5, 16, 12}).ok());
  }
  if (parts.imu_to_camera) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.01, 0.02, 0.03);
    EXPECT_TRUE(writer->set_T_camera_imu(T).ok());
  }
  if (!parts.gyro_noise_density.empty()) {
    EXPECT_TRUE(writer->set_info("gyro_noise_density", parts.gyro_noise_density).ok());
  }
  EXPECT_TRUE(writer->finish().ok());
  return path;
}

TEST(SequenceConfig, TakesCalibrationMountingAndGyroNoise) {
  TempDir dir;
  auto reader = SequenceReader::open(write_sequence(dir, {}));
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  auto c = sequence_config(SensorPreset::kKinect, *reader);
  ASSERT_TRUE(c.ok()) << c.error().describe();
  EXPECT_TRUE(c->validate().ok());
  EXPECT_EQ(c->intrinsics.width, 16);
  EXPECT_EQ(c->intrinsics.height, 12);
  EXPECT_DOUBLE_EQ(c->intrinsics.fy, 21);
  EXPECT_TRUE(c->imu.enabled);
  EXPECT_EQ(c->icp.max_total_iterations, kPresetIcpIterationsWithImu);
  EXPECT_TRUE(c->inertial.T_camera_imu_known);
  EXPECT_TRUE(c->inertial.T_camera_imu.isApprox(reader->info().T_camera_imu));
  EXPECT_NEAR(c->inertial.T_camera_imu.translation().z(), 0.03, 1e-9);
  EXPECT_DOUBLE_EQ(c->inertial.gyro_noise_density, 0.005);

  auto without = sequence_config(SensorPreset::kKinect, *reader, /*with_imu=*/false);
  ASSERT_TRUE(without.ok());
  EXPECT_FALSE(without->imu.enabled);
  EXPECT_EQ(without->icp.max_total_iterations, kPresetIcpIterationsWithoutImu);
}

TEST(SequenceConfig, EstimatesMountingAndKeepsDefaultNoiseWhenNotGiven) {
  TempDir dir;
  auto reader = SequenceReader::open(
      write_sequence(dir, {.imu_to_camera = false, .gyro_noise_density = "x"}));
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  auto c = sequence_config(SensorPreset::kKinect, *reader);
  ASSERT_TRUE(c.ok());
  EXPECT_TRUE(c->imu.enabled);
  EXPECT_FALSE(c->inertial.T_camera_imu_known);
  EXPECT_DOUBLE_EQ(c->inertial.gyro_noise_density, InertialConfig{}.gyro_noise_density);
}

TEST(SequenceConfig, LeavesOutAnImuOnAnotherClock) {
  TempDir dir;
  auto reader = SequenceReader::open(write_sequence(dir, {.imu_offset = 100}));
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  auto c = sequence_config(SensorPreset::kKinect, *reader);
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(c->imu.enabled);
  EXPECT_EQ(c->icp.max_total_iterations, kPresetIcpIterationsWithoutImu);
}

TEST(SequenceConfig, FailsNamingTheMissingCalibration) {
  TempDir dir;
  auto reader = SequenceReader::open(write_sequence(dir, {.calibration = false}));
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  auto c = sequence_config(SensorPreset::kKinect, *reader);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(c.error().message.find("calibration.txt"), std::string::npos);
}

}  // namespace
}  // namespace imufusion
