#pragma once
// Helpers for the inertial navigation tests: rotation error and a loop that runs a navigator
// along a synthetic camera motion with the true poses as the tracked ones.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <vector>

#include "imufusion/inertial.hpp"
#include "imufusion/synth.hpp"

namespace imufusion::test {

constexpr double kDeg = std::numbers::pi / 180.0;

inline double rotation_angle(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle(); }

inline double angle_between(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return rotation_angle(A.transpose() * B);
}

struct RunOptions {
  double start = 10.0;     // s, sequence clock of the first frame
  double duration = 20.0;  // s
  double fps = 30.0;
  synth::ImuConfig imu;  // noise, bias and mounting of the generated samples
  std::uint64_t seed = 1;
  /// Called after every observe() with the frame index and time.
  std::function<void(const InertialNavigator&, int, double)> after_frame;
  /// Which frames count as reliable (default: all).
  std::function<bool(double)> reliable = [](double) { return true; };
};

/// Feeds the samples of each frame interval, then observe() with the true poses.
inline InertialNavigator run_true_poses(const synth::CameraMotion& motion,
                                        const InertialConfig& config, const RunOptions& o,
                                        const synth::ImuBias& bias) {
  Result<InertialNavigator> created = InertialNavigator::create(config);
  EXPECT_TRUE(created.ok()) << (created.ok() ? "" : created.error().describe());
  InertialNavigator nav = std::move(created).value();
  const std::vector<ImuSample> samples =
      synth::generate_imu(motion, o.imu, bias, o.start - 0.1, o.start + o.duration + 0.1, o.seed);
  std::size_t next = 0;
  const int frames = static_cast<int>(o.duration * o.fps);
  for (int k = 0; k <= frames; ++k) {
    const double t = o.start + k / o.fps;
    // Samples up to just past the frame, as a driver delivers them.
    std::size_t end = next;
    while (end < samples.size() && samples[end].timestamp <= t + 0.006) ++end;
    EXPECT_TRUE(nav.add_samples(std::span(samples).subspan(next, end - next)).ok());
    next = end;
    if (k > 0) {
      const double ta = t - 1.0 / o.fps;
      nav.observe(ta, t, motion.pose_at(ta), motion.pose_at(t), o.reliable(t));
    }
    if (o.after_frame) o.after_frame(nav, k, t);
  }
  return nav;
}

}  // namespace imufusion::test
