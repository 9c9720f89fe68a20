// IMU samples and their integration between two instants (gyro rotation with its bias Jacobian,
// specific force rotated into the world). The rate rule is documented in inertial.hpp.

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/inertial_internal.hpp"
#include "core/state_fields.hpp"

namespace imufusion::inertial {

namespace {

std::string format_time(double t) {
  std::ostringstream os;
  os.precision(6);
  os << std::fixed << t;
  return os.str();
}

}  // namespace

SampleBuffer::SampleBuffer(double max_extrapolation, double max_sample_gap, double history)
    : max_extrapolation_(max_extrapolation), max_sample_gap_(max_sample_gap), history_(history) {}

Status SampleBuffer::append(std::span<const ImuSample> samples) {
  // Check the whole batch before touching the buffer, so an error applies nothing.
  double previous = latest_time();
  for (const ImuSample& s : samples) {
    const auto bad = [&](const char* what, double value) {
      std::ostringstream os;
      os << "IMU sample at t = " << format_time(s.timestamp) << " s: " << what << " is " << value;
      return make_error(ErrorCode::kInvalidArgument, os.str());
    };
    if (!std::isfinite(s.timestamp)) return bad("the timestamp", s.timestamp);
    for (int a = 0; a < 3; ++a) {
      static const char* const kGyro[] = {"gyro x", "gyro y", "gyro z"};
      static const char* const kAccel[] = {"accel x", "accel y", "accel z"};
      if (!std::isfinite(s.gyro[a])) return bad(kGyro[a], s.gyro[a]);
      if (!std::isfinite(s.accel[a])) return bad(kAccel[a], s.accel[a]);
    }
    if (s.timestamp < previous) {
      return make_error(
          ErrorCode::kInvalidArgument,
          "IMU sample at t = " + format_time(s.timestamp) +
              " s is older than the sample before it at t = " + format_time(previous) + " s");
    }
    previous = s.timestamp;
  }
  for (const ImuSample& s : samples) {
    if (!samples_.empty() && s.timestamp == samples_.back().timestamp) {
      // Two readings of one instant: keep their running mean.
      ImuSample& back = samples_.back();
      const double w = 1.0 / static_cast<double>(++last_merged_);
      back.gyro += w * (s.gyro - back.gyro);
      back.accel += w * (s.accel - back.accel);
      continue;
    }
    samples_.push_back(s);
    last_merged_ = 1;
  }
  const double oldest_kept = latest_time() - history_;
  while (samples_.size() > 2 && samples_[1].timestamp < oldest_kept) samples_.pop_front();
  return {};
}

double SampleBuffer::latest_time() const {
  return samples_.empty() ? -std::numeric_limits<double>::infinity() : samples_.back().timestamp;
}

SampleBuffer::Rate SampleBuffer::rate_at(double t) const {
  Rate rate;
  const auto it = std::lower_bound(samples_.begin(), samples_.end(), t,
                                   [](const ImuSample& s, double v) { return s.timestamp < v; });
  const auto i = static_cast<std::size_t>(it - samples_.begin());
  const std::size_t n = samples_.size();
  if (i < n && samples_[i].timestamp == t) {
    rate.kind = RateKind::kInterpolated;
    rate.gyro = samples_[i].gyro;
    rate.accel = samples_[i].accel;
    rate.first = rate.last = i;
    return rate;
  }
  if (i > 0 && i < n && samples_[i].timestamp - samples_[i - 1].timestamp <= max_sample_gap_) {
    const ImuSample& s0 = samples_[i - 1];
    const ImuSample& s1 = samples_[i];
    const double w = (t - s0.timestamp) / (s1.timestamp - s0.timestamp);
    rate.kind = RateKind::kInterpolated;
    rate.gyro = (1.0 - w) * s0.gyro + w * s1.gyro;
    rate.accel = (1.0 - w) * s0.accel + w * s1.accel;
    rate.first = i - 1;
    rate.last = i;
    return rate;
  }
  // Outside the samples or inside a dropout: hold the nearest sample, if near enough.
  double best = std::numeric_limits<double>::infinity();
  std::size_t nearest = 0;
  if (i > 0 && t - samples_[i - 1].timestamp < best) {
    best = t - samples_[i - 1].timestamp;
    nearest = i - 1;
  }
  if (i < n && samples_[i].timestamp - t < best) {
    best = samples_[i].timestamp - t;
    nearest = i;
  }
  if (best <= max_extrapolation_) {
    rate.kind = RateKind::kHeld;
    rate.gyro = samples_[nearest].gyro;
    rate.accel = samples_[nearest].accel;
    rate.first = rate.last = nearest;
  }
  return rate;
}

std::vector<double> SampleBuffer::breakpoints(double ta, double tb) const {
  std::vector<double> points{ta, tb};
  const auto add = [&](double t) {
    if (t > ta && t < tb) points.push_back(t);
  };
  const double margin = max_sample_gap_ + max_extrapolation_;
  auto it = std::lower_bound(samples_.begin(), samples_.end(), ta - margin,
                             [](const ImuSample& s, double v) { return s.timestamp < v; });
  if (it != samples_.begin()) --it;
  for (; it != samples_.end() && it->timestamp <= tb + margin; ++it) {
    add(it->timestamp);
    const auto next = std::next(it);
    // Where the rule changes: the hold limits around every sample bordering a dropout or the
    // ends of the data, and the middle of a dropout (where the nearest sample changes).
    const bool gap_after =
        next == samples_.end() || next->timestamp - it->timestamp > max_sample_gap_;
    const bool gap_before =
        it == samples_.begin() || it->timestamp - std::prev(it)->timestamp > max_sample_gap_;
    if (gap_after) add(it->timestamp + max_extrapolation_);
    if (gap_before) add(it->timestamp - max_extrapolation_);
    if (next != samples_.end() && gap_after) add(0.5 * (it->timestamp + next->timestamp));
  }
  std::sort(points.begin(), points.end());
  points.erase(std::unique(points.begin(), points.end()), points.end());
  return points;
}

ImuIntegration SampleBuffer::integrate(double ta, double tb, const Eigen::Vector3d& bias,
                                       const Eigen::Matrix3d& R_world_imu_a) const {
  ImuIntegration out;
  out.bias_used = bias;
  if (!(tb > ta)) {
    out.complete = rate_at(ta).kind != RateKind::kNone;
    out.covered_fraction = rate_at(ta).kind == RateKind::kInterpolated ? 1.0 : 0.0;
    return out;
  }
  const std::vector<double> points = breakpoints(ta, tb);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // IMU at the piece start into IMU at ta
  double covered = 0;
  bool complete = true;
  std::size_t first = samples_.size(), last = 0;
  for (std::size_t k = 0; k + 1 < points.size(); ++k) {
    const double dt = points[k + 1] - points[k];
    // Rates are linear within a piece, so the midpoint rate is the mean over it.
    const Rate rate = rate_at(points[k] + 0.5 * dt);
    if (rate.kind == RateKind::kNone) {
      complete = false;
      continue;
    }
    if (rate.kind == RateKind::kInterpolated) covered += dt;
    first = std::min(first, rate.first);
    last = std::max(last, rate.last);
    const Eigen::Vector3d phi = (rate.gyro - bias) * dt;
    const Eigen::Matrix3d step = exp_so3(phi);
    const Eigen::Matrix3d R_world_imu_mid = R_world_imu_a * R * exp_so3(0.5 * phi);
    const Eigen::Vector3d f_world = R_world_imu_mid * rate.accel;
    out.delta_p += out.delta_v * dt + 0.5 * f_world * dt * dt;
    out.delta_v += f_world * dt;
    out.Jp_accel += out.Jv_accel * dt + 0.5 * R_world_imu_mid * dt * dt;
    out.Jv_accel += R_world_imu_mid * dt;
    out.J_bias = step.transpose() * out.J_bias - right_jacobian_so3(phi) * dt;
    R = R * step;
  }
  out.R_a_b = R;
  out.complete = complete;
  out.covered_fraction = covered / (tb - ta);
  out.samples_used =
      first <= last && first < samples_.size() ? static_cast<int>(last - first + 1) : 0;
  return out;
}

void SampleBuffer::describe(StateArchive& archive) { archive(samples_, last_merged_); }

}  // namespace imufusion::inertial
