// ReconstructorConfig::validate: each setting out of range is refused, naming it.

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "imufusion/presets.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

TEST(ReconstructorConfig, RejectsSettingsOutOfRange) {
  ReconstructorConfig c;
  EXPECT_FALSE(c.validate().ok());  // no intrinsics
  c.intrinsics = synth::default_intrinsics(160, 120);
  EXPECT_TRUE(c.validate().ok());
  c.tracking.recovery_frames = 0;
  auto s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("recovery_frames"), std::string::npos);
  c.tracking.recovery_frames = 3;
  c.tracking.constant_velocity_pairs = -1;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("constant_velocity_pairs"), std::string::npos);
  c.tracking.constant_velocity_pairs = 0;  // the previous pose as the seed
  EXPECT_TRUE(c.validate().ok());
  for (const int level : {-2, c.preprocess.levels}) {
    c.tracking_level = level;
    s = c.validate();
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("tracking_level"), std::string::npos);
  }
  c.tracking_level = c.preprocess.levels - 1;
  EXPECT_TRUE(c.validate().ok());
  c.smoothing.gravity_sigma_scale = 0;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("drift sigma"), std::string::npos);
  c.smoothing.gravity_sigma_scale = 2.3;
  c.smoothing.gyro_bias_sigma_scale = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(c.validate().ok());
  c.smoothing.gyro_bias_sigma_scale = 0.3;
  EXPECT_TRUE(c.validate().ok());
  c.icp.depth_noise.b = -0.001;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("depth noise"), std::string::npos);
  c.icp.depth_noise.b = 0.0019;
  EXPECT_TRUE(c.validate().ok());
  c.smoothing.retrack_frames = -1;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("smoothing.retrack_frames"), std::string::npos);
  c.smoothing.retrack_frames = 0;
  c.smoothing.partial_move_sigma = -0.01;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("partial_move_sigma"), std::string::npos);
  c.smoothing.partial_move_sigma = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(c.validate().ok());
  c.smoothing.partial_move_sigma = 0;  // the moves not recorded
  EXPECT_TRUE(c.validate().ok());
  c.smoothing.retracked_frame_sigma = -0.003;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("retracked_frame_sigma"), std::string::npos);
  c.smoothing.retracked_frame_sigma = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(c.validate().ok());
  c.smoothing.retracked_frame_sigma = 0;  // the oldest frame placed is the end
  EXPECT_TRUE(c.validate().ok());
  c.recovery.agreement_distance = -0.05;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("recovery.agreement_distance"), std::string::npos);
  c.recovery.agreement_distance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(c.validate().ok());
  c.recovery.agreement_distance = 0;  // no check
  EXPECT_TRUE(c.validate().ok());
  c.initial_pose.translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(c.validate().ok());
}

// A preset is a valid configuration for the camera it is given, with the ICP budget of its IMU
// use: the gyro's seed needs 2 Gauss-Newton steps per frame, ICP alone up to 30.
TEST(SensorPresets, AreValidAndFollowTheImu) {
  const Intrinsics k = synth::default_intrinsics(640, 480);
  for (const bool imu : {true, false}) {
    const ReconstructorConfig c = preset_config(SensorPreset::kKinect, k, imu);
    EXPECT_TRUE(c.validate().ok()) << c.validate().error().describe();
    EXPECT_EQ(c.intrinsics.width, 640);
    EXPECT_EQ(c.intrinsics.fx, k.fx);
    EXPECT_EQ(c.imu.enabled, imu);
    EXPECT_EQ(c.icp.max_total_iterations, imu ? 2 : 30);
    EXPECT_FALSE(c.inertial.T_camera_imu_known);  // the mounting is the app's to give
  }
  EXPECT_EQ(parse_sensor_preset(to_string(SensorPreset::kKinect)), SensorPreset::kKinect);
  EXPECT_FALSE(parse_sensor_preset("kinect2").has_value());
  EXPECT_FALSE(preset_config(SensorPreset::kKinect, Intrinsics{}, true).validate().ok());
}

}  // namespace
}  // namespace imufusion
