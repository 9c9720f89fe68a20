#include "imufusion/clock_offset.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

namespace imufusion {

double HostClockMapper::observe(double host_receive_time, double sensor_time) {
  const double observed = host_receive_time - sensor_time;
  if (!offset_) {
    offset_ = observed;
  } else {
    // The envelope may rise only as fast as the clocks can drift apart; it drops at once to any
    // smaller difference (a message that travelled faster).
    const double elapsed = std::max(0.0, sensor_time - last_sensor_time_);
    offset_ = std::min(*offset_ + max_drift_ * elapsed, observed);
  }
  last_sensor_time_ = std::max(last_sensor_time_, sensor_time);
  return sensor_time + *offset_;
}

std::optional<double> HostClockMapper::offset() const { return offset_; }

ClockOffsetEstimator::ClockOffsetEstimator(const ClockOffsetOptions& options) : options_(options) {}

void ClockOffsetEstimator::add_imu(const ImuSample& sample, double host_receive_time) {
  if (!gyro_.empty() && !(sample.timestamp > gyro_.back().t)) return;
  arrival_.observe(host_receive_time, sample.timestamp);
  has_arrival_ = true;
  add_imu(sample);
}

void ClockOffsetEstimator::add_imu(const ImuSample& sample) {
  if (!std::isfinite(sample.timestamp) || !sample.gyro.allFinite()) return;
  if (gyro_.empty()) {
    gyro_.push_back({sample.timestamp, sample.gyro, Eigen::Vector3d::Zero()});
    return;
  }
  const Gyro& last = gyro_.back();
  if (!(sample.timestamp > last.t)) return;
  const double h = sample.timestamp - last.t;
  gyro_.push_back(
      {sample.timestamp, sample.gyro, last.integral + 0.5 * h * (last.rate + sample.gyro)});
  forget_old();
}

void ClockOffsetEstimator::add_camera_rate(double previous_frame_time, double frame_time,
                                           double rate) {
  if (!std::isfinite(previous_frame_time) || !std::isfinite(frame_time) || !std::isfinite(rate) ||
      !(frame_time > previous_frame_time)) {
    return;
  }
  if (!intervals_.empty() && !(frame_time > intervals_.back().end)) return;
  intervals_.push_back({previous_frame_time, frame_time, rate});
  forget_old();
}

void ClockOffsetEstimator::forget_old() {
  if (!intervals_.empty()) {
    const double oldest = intervals_.back().end - options_.history;
    while (!intervals_.empty() && intervals_.front().begin < oldest) intervals_.pop_front();
  }
  if (gyro_.size() < 2) return;
  // IMU samples are kept for the history plus the search radius around any plausible offset;
  // without camera intervals yet, for the history alone (on the IMU clock).
  const double keep = options_.history + 2.0 * options_.search_radius + 1.0;
  while (gyro_.size() > 2 && gyro_[1].t < gyro_.back().t - keep) gyro_.pop_front();
}

Eigen::Vector3d ClockOffsetEstimator::integral_at(double t) const {
  auto it = std::upper_bound(gyro_.begin(), gyro_.end(), t,
                             [](double value, const Gyro& g) { return value < g.t; });
  if (it == gyro_.begin()) return gyro_.front().integral;
  if (it == gyro_.end()) return gyro_.back().integral;
  const Gyro& a = *(it - 1);
  const Gyro& b = *it;
  const double h = b.t - a.t;
  const double dt = t - a.t;
  // Exact integral of the linear interpolation between the two samples.
  return a.integral + a.rate * dt + 0.5 * (b.rate - a.rate) * dt * dt / h;
}

double ClockOffsetEstimator::mean_rate(double begin, double end) const {
  return (integral_at(end) - integral_at(begin)).norm() / (end - begin);
}

namespace {

// Normalized cross-correlation of the camera rates of intervals [first, last) with the gyro
// rates at one lag; -1 when either signal is constant.
double normalized_correlation(const std::vector<double>& camera_rates,
                              const std::vector<double>& gyro_rates, std::size_t first,
                              std::size_t last) {
  const auto n = static_cast<double>(last - first);
  if (n < 2.0) return -1.0;
  double camera_mean = 0.0, gyro_mean = 0.0;
  for (std::size_t k = first; k < last; ++k) {
    camera_mean += camera_rates[k];
    gyro_mean += gyro_rates[k];
  }
  camera_mean /= n;
  gyro_mean /= n;
  double cross = 0.0, camera_ss = 0.0, gyro_ss = 0.0;
  for (std::size_t k = first; k < last; ++k) {
    const double c = camera_rates[k] - camera_mean;
    const double g = gyro_rates[k] - gyro_mean;
    cross += c * g;
    camera_ss += c * c;
    gyro_ss += g * g;
  }
  if (!(camera_ss > 0.0 && gyro_ss > 0.0)) return -1.0;
  return cross / std::sqrt(camera_ss * gyro_ss);
}

// The lag index (fractional) of the interior maximum of `ncc`, refined by the vertex of the
// parabola through it and its neighbours; nullopt when the maximum lies on the border or the
// correlation there is not positive.
std::optional<double> peak_lag(const std::vector<double>& ncc) {
  const auto best = static_cast<int>(std::max_element(ncc.begin(), ncc.end()) - ncc.begin());
  const int last = static_cast<int>(ncc.size()) - 1;
  if (best == 0 || best == last || ncc[best] <= 0.0) return std::nullopt;
  const double left = ncc[best - 1], peak = ncc[best], right = ncc[best + 1];
  const double curvature = left - 2.0 * peak + right;
  double shift = 0.0;
  if (curvature < 0.0) shift = std::clamp(0.5 * (left - right) / curvature, -0.5, 0.5);
  return best + shift;
}

// Population standard deviation of `values` (at least one).
double standard_deviation(const std::vector<double>& values) {
  const auto n = static_cast<double>(values.size());
  double mean = 0.0;
  for (double value : values) mean += value;
  mean /= n;
  double ss = 0.0;
  for (double value : values) ss += (value - mean) * (value - mean);
  return std::sqrt(ss / n);
}

// The normalized cross-correlation of camera and gyro rates at each lag of the search, over all
// intervals and over consecutive sub-windows of them.
struct LagCorrelations {
  std::vector<double> all;                   // per lag
  std::vector<std::vector<double>> windows;  // per sub-window, per lag
};

// Correlations at the 2 * steps + 1 offsets centre + (i - steps) * lag_step (seconds), over
// `blocks` sub-windows too: the spread of the sub-windows' peaks measures how well the data pin
// the offset down. gyro_rates(offset, rates) fills the gyro rate of each interval at an offset.
template <typename GyroRates>
LagCorrelations correlate_lags(const std::vector<double>& camera_rates, double centre, int steps,
                               double lag_step, int blocks, const GyroRates& gyro_rates) {
  const int lags = 2 * steps + 1;
  LagCorrelations ncc{std::vector<double>(lags, -1.0),
                      std::vector<std::vector<double>>(blocks, std::vector<double>(lags, -1.0))};
  const std::size_t count = camera_rates.size();
  std::vector<double> rates(count);
  const auto block_begin = [&](int b) { return count * b / blocks; };
  for (int i = 0; i < lags; ++i) {
    gyro_rates(centre + (i - steps) * lag_step, rates);
    ncc.all[i] = normalized_correlation(camera_rates, rates, 0, count);
    for (int b = 0; b < blocks; ++b) {
      ncc.windows[b][i] =
          normalized_correlation(camera_rates, rates, block_begin(b), block_begin(b + 1));
    }
  }
  return ncc;
}

// Standard error (in lags) of `peak` from the sub-windows' peaks, as of a mean of independent
// estimates. A sub-window without a positive interior maximum counts at its best lag (on the
// border of the search for a slope): it pins nothing down.
double peak_standard_error(const std::vector<std::vector<double>>& windows, double peak) {
  const auto blocks = static_cast<int>(windows.size());
  double spread = 0.0;
  for (const std::vector<double>& ncc : windows) {
    const std::optional<double> block_peak = peak_lag(ncc);
    const double lag =
        block_peak ? *block_peak
                   : static_cast<double>(std::max_element(ncc.begin(), ncc.end()) - ncc.begin());
    spread += (lag - peak) * (lag - peak);
  }
  return std::sqrt(spread / (blocks * (blocks - 1.0)));
}

}  // namespace

ClockOffsetEstimate ClockOffsetEstimator::estimate() const {
  ClockOffsetEstimate result;
  std::optional<double> centre;
  if (has_arrival_) {
    centre = arrival_.offset();
    result.source = ClockOffsetEstimate::Source::kArrival;
    result.offset = *centre;
  } else if (prior_offset_) {
    centre = prior_offset_;
    result.offset = *prior_offset_;
  }
  if (!centre || gyro_.size() < 2) return result;

  // Intervals whose shifted span lies inside the IMU data for every lag searched, so that all
  // lags are compared on the same samples.
  const double radius = options_.search_radius;
  std::vector<const Interval*> used;
  for (const Interval& interval : intervals_) {
    if (interval.begin - *centre - radius >= gyro_.front().t &&
        interval.end - *centre + radius <= gyro_.back().t) {
      used.push_back(&interval);
    }
  }
  if (used.size() < options_.min_intervals) return result;
  std::vector<double> camera_rates(used.size());
  for (std::size_t k = 0; k < used.size(); ++k) camera_rates[k] = used[k]->rate;
  if (standard_deviation(camera_rates) < options_.min_rate_std) return result;

  const int blocks = std::max(2, options_.blocks);
  const int steps = std::max(1, static_cast<int>(std::lround(radius / options_.lag_step)));
  const auto gyro_rates = [&](double offset, std::vector<double>& rates) {
    for (std::size_t k = 0; k < used.size(); ++k) {
      rates[k] = mean_rate(used[k]->begin - offset, used[k]->end - offset);
    }
  };
  const LagCorrelations ncc =
      correlate_lags(camera_rates, *centre, steps, options_.lag_step, blocks, gyro_rates);
  const std::optional<double> peak = peak_lag(ncc.all);
  // A peak on the border of the search is a slope, not a maximum: keep the arrival estimate.
  if (!peak) return result;
  const double standard_error = peak_standard_error(ncc.windows, *peak) * options_.lag_step;

  result.correlation = *std::max_element(ncc.all.begin(), ncc.all.end());
  result.standard_error = standard_error;
  result.intervals = used.size();
  result.correlation_offset = *centre + (*peak - steps) * options_.lag_step;
  // Not sharper than the arrival-time bound: keep that. Without arrival times the search
  // centre is only a prior guess, so the correlation is taken whatever its error.
  if (!(standard_error <= options_.max_standard_error) && has_arrival_) return result;
  result.source = ClockOffsetEstimate::Source::kCorrelation;
  result.offset = result.correlation_offset;
  result.confidence = std::clamp(1.0 - standard_error / options_.max_standard_error, 0.0, 1.0);
  return result;
}

}  // namespace imufusion
