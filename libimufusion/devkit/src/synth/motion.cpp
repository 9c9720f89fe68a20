// Hand-held camera trajectories through the synthetic room (world z up, metres, seconds).
//
// The base path is an elliptic orbit around the central furniture (centre (3, 2.5), radii
// 1.7 x 1.3 m, eye height ~1.45 m) looking at a slowly wandering point above the table, so the
// table group is seen at 1-2 m and the walls behind it at 3-4.5 m in every frame. Hand shake is
// a sum of sinusoids. Everything is smooth (C-infinity except the C2 blends below), so the IMU
// can be derived by differentiation.

#include <algorithm>
#include <cmath>
#include <numbers>

#include "imufusion/synth.hpp"
#include "synth/random.hpp"

namespace imufusion::synth {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

const Eigen::Vector2d kOrbitCenter(3.0, 2.5);
constexpr double kOrbitRx = 1.7, kOrbitRy = 1.3;   // metres
constexpr double kEyeHeight = 1.45;                // metres
const Eigen::Vector3d kLookTarget(3.0, 2.5, 0.7);  // above the table, metres

// Wall episode (seconds after start): turn to the wall, face it, turn back.
constexpr double kTurnInBegin = 0.5;
constexpr double kStretchBegin = 4.0;
constexpr double kStretchEnd = 6.0;
constexpr double kTurnOutEnd = 9.5;
constexpr double kStretchMid = 0.5 * (kStretchBegin + kStretchEnd);
constexpr double kWallCameraX = 5.0;  // 1 m in front of the x = 6 wall
constexpr double kWallSpeed = 0.3;    // m/s along the wall (y)
constexpr double kOrbitEase = 0.5;    // s: the orbit stops over this, and starts again over this

// Fast scene: rotation bursts every kBurstPeriod seconds, each a sin^4 bump of kBurstYaw over
// kBurstDuration (peak rate 1.3 pi A / D = ~67 deg/s; each bump turns out and back, so one half
// adds to the orbit's own ~23 deg/s turn and the hand shake: peaks of ~90-100 deg/s), with a
// sideways step of the hand.
constexpr double kBurstPeriod = 3.0;
constexpr double kBurstFirst = 1.0;
constexpr double kBurstDuration = 1.1;
constexpr double kBurstYaw = 18.0 * kDeg;
constexpr double kBurstPitch = 8.0 * kDeg;
constexpr double kBurstShift = 0.08;  // metres

/// 0 -> 1 over [a, b], C2 (quintic smoothstep).
double smooth_step(double a, double b, double x) {
  const double s = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return s * s * s * (s * (6.0 * s - 15.0) + 10.0);
}

/// Integral of smooth_step(0, 1, x) from 0 to x, for x in [0, 1].
double smooth_step_integral(double x) {
  const double s = std::clamp(x, 0.0, 1.0);
  return s * s * s * s * (s * (s - 3.0) + 2.5);
}

/// sin^4 bump on [0, 1]: zero with three vanishing derivatives at both ends.
double bump(double x) {
  if (x <= 0.0 || x >= 1.0) return 0.0;
  const double s = std::sin(kPi * x);
  return s * s * s * s;
}

CameraMotion::Wave random_wave(Rng& rng, double amp_lo, double amp_hi, double f_lo, double f_hi) {
  CameraMotion::Wave w;
  w.amplitude = rng.uniform(amp_lo, amp_hi);
  w.frequency_hz = rng.uniform(f_lo, f_hi);
  w.phase = rng.uniform(0.0, 2.0 * kPi);
  return w;
}

}  // namespace

double CameraMotion::Wave::at(double tau) const {
  return amplitude * std::sin(2.0 * kPi * frequency_hz * tau + phase);
}

CameraMotion::CameraMotion(SceneKind kind, std::uint64_t seed, double start_time)
    : kind_(kind), start_time_(start_time) {
  Rng rng(mix_seed(seed, 202));
  direction_ = rng.sign();
  phase0_ = rng.uniform(0.0, 2.0 * kPi);
  speed_ = kind == SceneKind::kFast ? 0.6 : 0.3;
  for (auto& axis : position_jitter_) {
    for (Wave& w : axis) w = random_wave(rng, 0.004, 0.012, 0.3, 1.2);
  }
  for (auto& axis : angle_jitter_) {
    for (Wave& w : axis) w = random_wave(rng, 0.3 * kDeg, 1.0 * kDeg, 0.2, 1.0);
  }
  target_wander_[0] = random_wave(rng, 0.2, 0.35, 0.04, 0.12);
  target_wander_[1] = random_wave(rng, 0.15, 0.25, 0.04, 0.12);
  target_wander_[2] = random_wave(rng, 0.05, 0.15, 0.05, 0.15);
  speed_wave_ = random_wave(rng, 0.1, 0.25, 0.05, 0.15);
  if (kind == SceneKind::kWall) {
    // The orbit pauses at the x = 6 side (orbit angle 0) for the wall episode.
    phase0_ = -direction_ * speed_ / (0.5 * (kOrbitRx + kOrbitRy)) * orbit_time(kStretchMid);
    speed_wave_.amplitude = 0.0;
  }
}

double CameraMotion::orbit_time(double tau) const {
  if (kind_ != SceneKind::kWall || tau <= kTurnInBegin) return tau;
  // The orbit's speed falls as 1 - smooth_step over kOrbitEase after the turn in begins and
  // rises back as smooth_step over kOrbitEase before the turn back ends (C2 in tau).
  const double stop_end = kTurnInBegin + kOrbitEase, start_begin = kTurnOutEnd - kOrbitEase;
  double t = kTurnInBegin + kOrbitEase * (std::min(tau, stop_end) - kTurnInBegin) / kOrbitEase -
             kOrbitEase * smooth_step_integral((tau - kTurnInBegin) / kOrbitEase);
  if (tau > start_begin) t += kOrbitEase * smooth_step_integral((tau - start_begin) / kOrbitEase);
  if (tau > kTurnOutEnd) t += tau - kTurnOutEnd;
  return t;
}

CameraMotion::LookPose CameraMotion::orbit_pose(double tau_walk) const {
  const double tau = orbit_time(tau_walk);
  const double omega = speed_ / (0.5 * (kOrbitRx + kOrbitRy));  // rad/s
  // Integral of (1 + speed wave): the walking speed varies by the wave's amplitude.
  const double f = speed_wave_.frequency_hz;
  const double warped =
      tau - speed_wave_.amplitude / (2.0 * kPi * f) *
                (std::cos(2.0 * kPi * f * tau + speed_wave_.phase) - std::cos(speed_wave_.phase));
  const double phi = phase0_ + direction_ * omega * warped;

  LookPose pose;
  pose.position = Eigen::Vector3d(kOrbitCenter.x() + kOrbitRx * std::cos(phi),
                                  kOrbitCenter.y() + kOrbitRy * std::sin(phi), kEyeHeight);
  for (int a = 0; a < 3; ++a) {
    pose.position[a] += position_jitter_[a][0].at(tau_walk) + position_jitter_[a][1].at(tau_walk);
  }
  Eigen::Vector3d target = kLookTarget;
  for (int a = 0; a < 3; ++a) target[a] += target_wander_[a].at(tau_walk);
  const Eigen::Vector3d view = target - pose.position;
  // Unwrap around the inward direction phi + pi, so yaw is continuous in tau.
  const double reference = phi + kPi;
  pose.yaw = reference + std::remainder(std::atan2(view.y(), view.x()) - reference, 2.0 * kPi);
  pose.pitch = std::atan2(view.z(), view.head<2>().norm());
  pose.roll = 0.0;

  if (kind_ == SceneKind::kFast) {
    // Alternating bursts; the k-th burst's sign flips with k and with the orbit direction.
    const int k = static_cast<int>(std::floor((tau - kBurstFirst) / kBurstPeriod));
    if (k >= 0) {
      const double b = bump((tau - kBurstFirst - k * kBurstPeriod) / kBurstDuration);
      const double sign = (k % 2 == 0 ? 1.0 : -1.0) * direction_;
      pose.yaw += sign * kBurstYaw * b;
      pose.pitch += (k % 3 == 1 ? kBurstPitch : -0.5 * kBurstPitch) * b;
      const Eigen::Vector3d side(-std::sin(pose.yaw), std::cos(pose.yaw), 0.0);
      pose.position += sign * kBurstShift * b * side;
    }
  }
  return pose;
}

CameraMotion::LookPose CameraMotion::wall_pose(double tau) const {
  // Facing +x at x = 5, walking along y at kWallSpeed, sweeping the view a few degrees.
  LookPose pose;
  pose.position = Eigen::Vector3d(
      kWallCameraX, kOrbitCenter.y() + direction_ * kWallSpeed * (tau - kStretchMid), kEyeHeight);
  for (int a = 0; a < 3; ++a) {
    pose.position[a] += position_jitter_[a][0].at(tau) + position_jitter_[a][1].at(tau);
  }
  pose.yaw = 5.0 * kDeg * std::sin(2.0 * kPi * 0.3 * tau + angle_jitter_[0][0].phase);
  pose.pitch = 2.5 * kDeg * std::sin(2.0 * kPi * 0.45 * tau + angle_jitter_[1][0].phase);
  pose.roll = 0.0;
  return pose;
}

CameraMotion::LookPose CameraMotion::look_pose(double tau) const {
  LookPose pose = orbit_pose(tau);
  if (kind_ == SceneKind::kWall && tau > kTurnInBegin && tau < kTurnOutEnd) {
    const LookPose wall = wall_pose(tau);
    const bool turning_in = tau < kStretchMid;
    const double w = turning_in ? smooth_step(kTurnInBegin, kStretchBegin, tau)
                                : 1.0 - smooth_step(kStretchEnd, kTurnOutEnd, tau);
    // Turn the short way round, judged once per turn (at the stretch's edge) and kept for the
    // whole turn, so that the yaw stays continuous in tau.
    const double edge = turning_in ? kStretchBegin : kStretchEnd;
    const double turns = std::round((wall_pose(edge).yaw - orbit_pose(edge).yaw) / (2.0 * kPi));
    const double dyaw = wall.yaw - pose.yaw - 2.0 * kPi * turns;
    pose.position = (1.0 - w) * pose.position + w * wall.position;
    pose.yaw += w * dyaw;
    pose.pitch += w * (wall.pitch - pose.pitch);
    pose.roll += w * (wall.roll - pose.roll);
  }
  // Hand shake of the view direction on top of everything.
  pose.yaw += angle_jitter_[0][0].at(tau) + angle_jitter_[0][1].at(tau);
  pose.pitch += angle_jitter_[1][0].at(tau) + angle_jitter_[1][1].at(tau);
  pose.roll += angle_jitter_[2][0].at(tau) + angle_jitter_[2][1].at(tau);
  return pose;
}

Eigen::Isometry3d CameraMotion::pose_at(double t) const {
  const LookPose p = look_pose(t - start_time_);
  const double cy = std::cos(p.yaw), sy = std::sin(p.yaw);
  const double cp = std::cos(p.pitch), sp = std::sin(p.pitch);
  const Eigen::Vector3d forward(cp * cy, cp * sy, sp);
  const Eigen::Vector3d right(sy, -cy, 0.0);  // forward x world-up, normalized
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d R;
  R.col(0) = right;
  R.col(1) = down;
  R.col(2) = forward;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R * Eigen::AngleAxisd(p.roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = p.position;
  return T;
}

std::optional<TimeSpan> CameraMotion::wall_stretch() const {
  if (kind_ != SceneKind::kWall) return std::nullopt;
  return TimeSpan{start_time_ + kStretchBegin, start_time_ + kStretchEnd};
}

double CameraMotion::episode_end() const { return kind_ == SceneKind::kWall ? kTurnOutEnd : 0.0; }

}  // namespace imufusion::synth
