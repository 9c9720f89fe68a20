// ReconstructorConfig::validate: each setting out of range is refused, naming it.

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "imufusion/presets.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

// `c` with `field` (one of its settings) at `bad`, NaN or infinity is refused, naming `name`;
// with `off` (0: the feature off) it is valid again, and the setting stays there.
void expect_checked(ReconstructorConfig& c, double& field, double bad, double off,
                    const std::string& name) {
  for (const double value :
       {bad, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    field = value;
    const auto s = c.validate();
    ASSERT_FALSE(s.ok()) << name << " = " << value;
    EXPECT_NE(s.error().message.find(name), std::string::npos) << s.error().message;
  }
  field = off;
  EXPECT_TRUE(c.validate().ok()) << name;
}

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
  for (int bad : {0, 4}) {
    c.tracking.relocalized_recovery_frames = bad;
    s = c.validate();
    ASSERT_FALSE(s.ok()) << bad;
    EXPECT_NE(s.error().message.find("relocalized_recovery_frames"), std::string::npos);
  }
  c.tracking.relocalized_recovery_frames = 3;
  EXPECT_TRUE(c.validate().ok());
  c.tracking.constant_velocity_pairs = -1;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("constant_velocity_pairs"), std::string::npos);
  c.tracking.constant_velocity_pairs = 0;  // the previous pose as the seed
  EXPECT_TRUE(c.validate().ok());
  c.tracking.restart_lost_frames = -1;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("restart_lost_frames"), std::string::npos);
  c.tracking.restart_lost_frames = 0;  // never
  c.tracking.restart_model_frames = -2;
  EXPECT_FALSE(c.validate().ok());
  c.tracking.restart_model_frames = 0;
  EXPECT_TRUE(c.validate().ok());
  for (const int level : {-2, c.preprocess.levels}) {
    c.tracking_level = level;
    s = c.validate();
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("tracking_level"), std::string::npos);
  }
  c.tracking_level = c.preprocess.levels - 1;
  EXPECT_TRUE(c.validate().ok());
  c.reference_frames = -1;
  s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("reference_frames"), std::string::npos);
  c.reference_frames = 1;
  for (const double pixels :
       {-1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    c.reference_motion_pixels = pixels;
    s = c.validate();
    ASSERT_FALSE(s.ok()) << pixels;
    EXPECT_NE(s.error().message.find("reference_motion_pixels"), std::string::npos);
  }
  c.reference_motion_pixels = 0;  // a raycast after every frame that moved at all
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
  expect_checked(c, c.smoothing.partial_move_sigma, -0.01, 0, "partial_move_sigma");
  expect_checked(c, c.smoothing.retracked_frame_sigma, -0.003, 0, "retracked_frame_sigma");
  expect_checked(c, c.relocalization.near_fit_condition_factor, -1, 0, "near_fit_condition_factor");
  expect_checked(c, c.relocalization.rival_residual_ratio, -1, 0, "rival_residual_ratio");
  expect_checked(c, c.relocalization.rival_inlier_ratio, -0.5, 0, "rival_inlier_ratio");
  expect_checked(c, c.relocalization.max_translation_condition, -1, 0, "max_translation_condition");
  expect_checked(c, c.relocalization.turned_condition_factor, 1.5, 1, "turned_condition_factor");
  expect_checked(c, c.relocalization.turned_condition_factor, 0, 0.5, "turned_condition_factor");
  expect_checked(c, c.tracking.residual_ratio, -1, 0, "tracking.residual_ratio");
  expect_checked(c, c.relocalization.turn_step_deg, 120, 0, "turn_step_deg");
  expect_checked(c, c.recovery.agreement_distance, -0.05, 0, "recovery.agreement_distance");
  c.initial_pose.translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(c.validate().ok());
}

// A preset is a valid configuration for the camera it is given, with the ICP budget of its IMU
// use: the gyro's seed needs 2 Gauss-Newton steps per frame, ICP alone up to 30.
TEST(SensorPresets, AreValidAndFollowTheImu) {
  for (const SensorPreset sensor : {SensorPreset::kKinect, SensorPreset::kPhoneToF}) {
    const Intrinsics k = sensor == SensorPreset::kKinect ? synth::default_intrinsics(640, 480)
                                                         : synth::default_intrinsics(240, 180);
    for (const bool imu : {true, false}) {
      const ReconstructorConfig c = preset_config(sensor, k, imu);
      EXPECT_TRUE(c.validate().ok()) << c.validate().error().describe();
      EXPECT_EQ(c.intrinsics.width, k.width);
      EXPECT_EQ(c.intrinsics.fx, k.fx);
      EXPECT_EQ(c.imu.enabled, imu);
      EXPECT_EQ(c.icp.max_total_iterations, imu ? 2 : 30);
      EXPECT_FALSE(c.inertial.T_camera_imu_known);  // the mounting is the app's to give
    }
    EXPECT_EQ(parse_sensor_preset(to_string(sensor)), sensor);
    EXPECT_FALSE(preset_config(sensor, Intrinsics{}, true).validate().ok());
  }
  EXPECT_STREQ(to_string(SensorPreset::kKinect), "kinect");
  EXPECT_STREQ(to_string(SensorPreset::kPhoneToF), "phone-tof");
  EXPECT_FALSE(parse_sensor_preset("kinect2").has_value());
  EXPECT_FALSE(parse_sensor_preset("phone_tof").has_value());
}

// The Kinect preset is the library's member defaults; the phone ToF one takes the sensor's
// 0.2-4 m range, its noise (the generator's model: 1 % of z), larger voxels and ICP on the depth
// alone (its voxels hold the colour too coarsely for the photometric term).
TEST(SensorPresets, PhoneToFTakesTheSensorsRangeAndNoise) {
  const ReconstructorConfig defaults;
  const ReconstructorConfig kinect =
      preset_config(SensorPreset::kKinect, synth::default_intrinsics(640, 480), true);
  EXPECT_EQ(kinect.preprocess.min_depth, defaults.preprocess.min_depth);
  EXPECT_EQ(kinect.volume.voxel_size, defaults.volume.voxel_size);
  EXPECT_EQ(kinect.icp.depth_noise.a, defaults.icp.depth_noise.a);
  EXPECT_EQ(kinect.icp.photometric.weight, defaults.icp.photometric.weight);
  EXPECT_GT(kinect.icp.photometric.weight, 0.0);

  const ReconstructorConfig tof =
      preset_config(SensorPreset::kPhoneToF, synth::default_intrinsics(240, 180), true);
  const synth::SensorModel sensor = synth::sensor_model(synth::SensorKind::kPhoneToF);
  EXPECT_FLOAT_EQ(tof.preprocess.min_depth, static_cast<float>(sensor.min_depth));
  EXPECT_FLOAT_EQ(tof.preprocess.max_depth, static_cast<float>(sensor.max_depth));
  EXPECT_GT(tof.volume.voxel_size, kinect.volume.voxel_size);
  EXPECT_EQ(tof.icp.photometric.weight, 0.0);
  for (double z = 0.8; z <= 4.0; z += 0.1) {
    const double model = synth::tof_noise_sigma(z, 0.5, 1.0);
    EXPECT_NEAR(tof.icp.depth_noise.sigma(z), model, 0.15 * model) << "z " << z;
  }
}

}  // namespace
}  // namespace imufusion
