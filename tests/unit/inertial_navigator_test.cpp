// InertialNavigator configuration checks and its state before any data.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "imufusion/inertial.hpp"

namespace imufusion {
namespace {

std::string create_error(const InertialConfig& config) {
  const Result<InertialNavigator> nav = InertialNavigator::create(config);
  return nav.ok() ? std::string() : nav.error().message;
}

TEST(InertialNavigator, DefaultConfigIsValid) {
  EXPECT_TRUE(InertialConfig{}.validate().ok());
  const Result<InertialNavigator> nav = InertialNavigator::create(InertialConfig{});
  ASSERT_TRUE(nav.ok());
  EXPECT_EQ(nav->latest_sample_time(), -std::numeric_limits<double>::infinity());
  EXPECT_FALSE(nav->covers(0.0));
  const MotionPrediction p = nav->predict(0.0, 0.1);
  EXPECT_FALSE(p.rotation_from_imu);
  EXPECT_FALSE(p.translation_predicted);
  EXPECT_TRUE(p.T_a_b.matrix().isIdentity(0));
  const InertialStatus st = nav->status();
  EXPECT_EQ(st.bias_updates, 0);
  EXPECT_FALSE(st.R_camera_imu_estimated);
  EXPECT_EQ(st.R_camera_imu_sigma_deg, 0.0);
  EXPECT_FALSE(st.gravity_ready);
}

TEST(InertialNavigator, BadConfigsNameTheField) {
  InertialConfig c;
  c.max_extrapolation = -0.1;
  EXPECT_NE(create_error(c).find("max_extrapolation"), std::string::npos);
  c = {};
  c.max_sample_gap = 0;
  EXPECT_NE(create_error(c).find("max_sample_gap = 0"), std::string::npos);
  c = {};
  c.gyro_bias_prior_sigma = std::nan("");
  EXPECT_NE(create_error(c).find("gyro_bias_prior_sigma"), std::string::npos);
  c = {};
  c.T_camera_imu.linear() *= 1.1;
  EXPECT_NE(create_error(c).find("T_camera_imu"), std::string::npos);
  c = {};
  c.T_camera_imu.linear() = -Eigen::Matrix3d::Identity();  // a reflection
  EXPECT_NE(create_error(c).find("determinant"), std::string::npos);
  c = {};
  c.initial_gyro_bias.x() = std::numeric_limits<double>::infinity();
  EXPECT_NE(create_error(c).find("initial_gyro_bias"), std::string::npos);
  c = {};
  c.translation = static_cast<TranslationModel>(7);
  EXPECT_NE(create_error(c).find("translation"), std::string::npos);
  c = {};
  c.hand_eye_min_pairs = 2;
  EXPECT_NE(create_error(c).find("hand_eye_min_pairs"), std::string::npos);
  c = {};
  c.hand_eye_max_pairs = c.hand_eye_min_pairs - 1;
  EXPECT_NE(create_error(c).find("hand_eye_max_pairs"), std::string::npos);
}

TEST(InertialNavigator, IntervalsThatAreNotIntervalsPredictNothing) {
  InertialNavigator nav = InertialNavigator::create(InertialConfig{}).value();
  std::vector<ImuSample> s(100);
  for (std::size_t i = 0; i < s.size(); ++i) {
    s[i].timestamp = 0.005 * static_cast<double>(i);
    s[i].gyro = Eigen::Vector3d(0.1, 0, 0);
  }
  ASSERT_TRUE(nav.add_samples(s).ok());
  EXPECT_FALSE(nav.predict(0.3, 0.2).rotation_from_imu);
  EXPECT_FALSE(nav.predict(std::nan(""), 0.2).rotation_from_imu);
  const MotionPrediction zero = nav.predict(0.2, 0.2);
  EXPECT_TRUE(zero.rotation_from_imu);
  EXPECT_TRUE(zero.T_a_b.matrix().isIdentity(1e-15));
  EXPECT_EQ(zero.rotation_sigma, 0.0);
  // Gyro white noise over the interval and the bias prior's uncertainty times its length.
  const InertialConfig c;
  const MotionPrediction p = nav.predict(0.1, 0.2);
  EXPECT_NEAR(p.rotation_sigma,
              std::sqrt(c.gyro_noise_density * c.gyro_noise_density * 0.1 +
                        c.gyro_bias_prior_sigma * c.gyro_bias_prior_sigma * 0.01),
              1e-9);
  EXPECT_EQ(p.translation_sigma, 0.0);  // nothing tracked yet
}

}  // namespace
}  // namespace imufusion
