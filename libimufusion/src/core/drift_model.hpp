#pragma once
// The drift model of a dead-reckoned stretch: how gyro bias, gravity and accelerometer bias
// errors and the start velocity's error grow into dead reckoning's pose errors, and the
// corrections of the stretch's frames given the error its end shows. Pure C++, no GPU.

#include <Eigen/Core>
#include <optional>
#include <vector>

namespace imufusion {

/// What is known about a dead-reckoned stretch's error sources when it began (1 sigma, per
/// axis). Zero sigmas are sources left out.
struct DriftPrior {
  Eigen::Vector3d gravity_world = Eigen::Vector3d::Zero();  // m/s^2; zero: no tilt term
  double velocity_sigma = 0;  // m/s: the velocity at the start; infinite: not yet measured
  // The joint covariance of the gravity estimate (world) and the accelerometer bias (camera
  // frame), m^2/s^4. Estimated together, their sum is known far better than either while the
  // camera turned little; a turn during the stretch shows their difference.
  Eigen::Matrix<double, 6, 6> gravity_bias_covariance = Eigen::Matrix<double, 6, 6>::Zero();
  double gyro_bias_sigma = 0;     // rad/s: the gyro bias estimate (camera frame); infinite: unknown
  double gyro_noise_density = 0;  // rad/s/sqrt(Hz): the gyro's white noise (angle random walk)
};

/// A frame inside a dead-reckoned stretch: its time since the stretch began (s), its estimated
/// orientation (the biases, constant in the camera frame, act along it) and the world
/// translation directions ICP fixed in it (a projector; zero for a frame dead-reckoned in all).
struct StretchFrame {
  double s = 0;
  Eigen::Matrix3d fixed = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d R_world_camera = Eigen::Matrix3d::Identity();
  // A frame placed from a seed that may lie beyond ICP's reach: how far ICP moved it from where
  // dead reckoning put it (world, metres), and that move's sigma per axis. A zero sigma: the
  // fixed directions are exact (the drift restarts there) and no move is recorded.
  Eigen::Vector3d moved = Eigen::Vector3d::Zero();
  double moved_sigma = 0;
  // How far ICP turned the frame from where dead reckoning put it (world rotation vector, rad:
  // estimate = Exp(turned) * dead-reckoned): the rotation error drops by it there.
  Eigen::Vector3d turned = Eigen::Vector3d::Zero();
  // A frame a recovery placed by ICP (backward from it): its position error, truth - estimate
  // (world), measured with this sigma per axis; zero: not measured.
  Eigen::Vector3d observed = Eigen::Vector3d::Zero();
  double observed_sigma = 0;
};

/// Truth - estimate of a dead-reckoned pose (world): truth = Exp(rotation) * estimate, position
/// + translation.
struct StretchCorrection {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();
};

/// The corrections of the frames of a dead-reckoned stretch [0, T] (`frames`, in time order,
/// strictly inside), whose error was zero at 0 and was measured at T by the recovery
/// (`end_translation`, `end_rotation`, as in StretchCorrection): the conditional mean under a
/// linear model of dead reckoning's errors, given the end error.
///   - Rotation error delta(s): the gyro bias error, constant in the camera frame and so turning
///     with the camera in the world (a camera that turns round undoes part of its drift), plus the
///     gyro's white noise (a random walk).
///   - Position: the rotation error tilts the gravity the accelerometer model removes, so the
///     corrected acceleration is -delta(s) x g, plus the accelerometer bias error (camera frame,
///     turning with the camera) and the gravity estimate's error (world); the velocity error at
///     the start adds a linear term.
///   - Where ICP turned a frame (`turned`), the rotation error drops by the turn: a partial
///     alignment that turned the last frames wrongly is undone there, not spread as gyro drift.
///   - Where ICP placed a frame partly (a bare wall fixes the distance to it), its position was
///     right along the fixed directions: the error there starts again from zero while the
///     velocity and bias errors run on.
///   - Where it placed a frame with a recorded move (`moved_sigma` > 0: late in a long loss),
///     the error drops by the move. Along the directions the frame fixed that the frame before
///     it did not (more than 45 degrees from their span), the move measures the error just
///     before it, with `moved_sigma`. Such measurements are taken in time order while each
///     raises the measurements' chi-square by no more than its 99.9th percentile for the degrees
///     of freedom it adds: one that contradicts the end error (an alignment that settled on
///     the wrong stretch of the model) is left out, its move still applied.
///   - Where a recovery placed a frame by ICP (`observed_sigma` > 0: the frames just before the
///     end), its position error is measured too. A few such frames measure how fast the error
///     still grew at the end, which the end error alone leaves to the prior.
/// The interval before a frame takes that frame's orientation, the last interval the last
/// frame's. The estimate's linear spread when a source's sigmas are all zero: with no rotation
/// source the rotation error grows linearly, with no translation source the velocity error takes
/// the rest.
std::vector<StretchCorrection> drift_corrections(const std::vector<StretchFrame>& frames, double T,
                                                 const Eigen::Vector3d& end_translation,
                                                 const Eigen::Vector3d& end_rotation,
                                                 const DriftPrior& prior);

/// The velocity error (truth - estimate, world, m/s) dead reckoning carried to the stretch's end
/// T, under the model and measurements of drift_corrections: the rate at which the corrections
/// grow there. None when T is not positive, or when the end error (with the moves taken) is not
/// what the prior lets dead reckoning drift: its chi-square above the 99.9th percentile for its
/// degrees of freedom (a pose already off when the stretch began, as after a slide along a
/// wall, not a drift whose rate the end could tell).
std::optional<Eigen::Vector3d> drift_end_velocity(const std::vector<StretchFrame>& frames, double T,
                                                  const Eigen::Vector3d& end_translation,
                                                  const Eigen::Vector3d& end_rotation,
                                                  const DriftPrior& prior);

}  // namespace imufusion
