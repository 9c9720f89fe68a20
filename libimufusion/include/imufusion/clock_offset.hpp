#pragma once
// Clock alignment for live scanning. A depth camera and a phone IMU run on different clocks; the
// scanner maps everything onto the host clock (seconds, e.g. host_clock_now() of imu_stream.hpp):
//
//   t_host = t_sensor + offset
//
// HostClockMapper maps a sensor's timestamps onto the host clock from arrival times alone (a
// lower envelope of host_receive - t_sensor: transport latency is never negative, so the
// smallest difference is the best bound). ClockOffsetEstimator refines the IMU's offset by
// correlating the gyroscope's angular-rate magnitude with the camera's rotation rate from ICP,
// which removes the latency bias the arrival times cannot see, when the motion pins it down
// better than that bias (a standard error from the correlation's sub-windows tells).

#include <cstddef>
#include <deque>
#include <optional>

#include "imufusion/types.hpp"

namespace imufusion {

/// Maps sensor timestamps onto the host clock from (host receive time, sensor time) pairs.
/// The offset is the lower envelope of host - sensor, allowed to rise by at most
/// `max_drift` seconds per second (clock rate difference), so that it follows a drifting
/// sensor clock without ever jumping up by a latency spike.
class HostClockMapper {
 public:
  /// `max_drift`: largest clock rate difference followed upwards (s/s); 2e-4 covers crystal
  /// oscillators (typically < 1e-4).
  explicit HostClockMapper(double max_drift = 2e-4) : max_drift_(max_drift) {}

  /// Records one observation and returns the sensor time mapped onto the host clock.
  double observe(double host_receive_time, double sensor_time);
  /// The current offset (host - sensor, seconds); nullopt before the first observation.
  std::optional<double> offset() const;
  double to_host(double sensor_time) const { return sensor_time + offset_.value_or(0.0); }

 private:
  double max_drift_;
  std::optional<double> offset_;
  double last_sensor_time_ = 0.0;
};

struct ClockOffsetOptions {
  /// Lags searched on either side of the arrival-time offset (seconds). Arrival times bound the
  /// offset from above (latency >= 0); Wi-Fi latency of a phone is tens of ms, so 0.25 s leaves
  /// a wide margin while keeping the search unambiguous for hand-held motion.
  double search_radius = 0.25;
  /// Step of the coarse lag grid (seconds); the peak is refined by a parabola through the best
  /// grid point and its neighbours.
  double lag_step = 0.002;
  /// Camera rotation rates older than this (seconds before the newest) are forgotten.
  double history = 30.0;
  /// Fewer camera intervals than this give no correlation estimate (at 30 Hz: 4 s).
  std::size_t min_intervals = 120;
  /// Standard deviation of the camera rotation rate below which the motion does not excite
  /// the correlation (rad/s): a camera held still has no rate signal to align.
  double min_rate_std = 0.05;
  /// The correlation is also computed over this many consecutive sub-windows of the camera
  /// intervals; the spread of their peaks gives the estimate's standard error.
  int blocks = 5;
  /// Largest standard error (seconds) at which the correlation replaces the arrival-time
  /// offset (whose bias is the smallest transport latency, a few ms over Wi-Fi).
  double max_standard_error = 0.005;
};

/// What the estimator knows about the offset (t_host = t_imu + offset).
struct ClockOffsetEstimate {
  enum class Source { kNone, kArrival, kCorrelation };
  Source source = Source::kNone;
  double offset = 0.0;  // seconds
  /// In [0, 1]: 0 for kNone and kArrival (an upper bound only, biased by the smallest
  /// latency); for kCorrelation 1 - standard_error / max_standard_error (1: exact, 0: at the
  /// limit of acceptance).
  double confidence = 0.0;
  /// Standard error of the correlation offset (seconds), from the spread of the peaks of its
  /// sub-windows; 0 when no correlation was computed. The correlation is used only when this
  /// is at most ClockOffsetOptions::max_standard_error. It tracks the actual error, which
  /// depends on how much the rotation rate varies: on synthetic 20 s sessions (0.03 rad/s ICP
  /// rate noise) fast hand-held motion gave SE 0.2-0.9 ms for errors below 0.8 ms, slow
  /// walking motion SE 5-24 ms for errors up to 34 ms; error / SE stayed within 3.2
  /// (tests/unit/clock_offset_test.cpp).
  double standard_error = 0.0;
  /// The correlation's offset, also when it was not accepted (then `offset` is the arrival
  /// time's); 0 when no correlation was computed.
  double correlation_offset = 0.0;
  double correlation = 0.0;   // peak normalized cross-correlation (when computed), else 0
  std::size_t intervals = 0;  // camera intervals used
};

/// Estimates the IMU clock offset. Feed it IMU samples (IMU clock) with their host arrival
/// times, and the camera's rotation rate between consecutive reliably tracked frames (host
/// clock); call estimate() when an estimate is needed (it costs O(lags x intervals x log n)).
class ClockOffsetEstimator {
 public:
  explicit ClockOffsetEstimator(const ClockOffsetOptions& options = {});

  /// One IMU sample (timestamp on the IMU clock) and the host time it arrived. Samples must
  /// come in increasing timestamp order; others are ignored.
  void add_imu(const ImuSample& sample, double host_receive_time);
  /// The IMU sample alone, when arrival times are unknown (e.g. a recorded stream); the
  /// correlation search then centres on `prior_offset`.
  void add_imu(const ImuSample& sample);
  /// The camera's rotation between two consecutive frames (host clock, seconds), as a rate:
  /// angle of R_prev^T R_curr divided by (frame_time - previous_frame_time), rad/s. Feed only
  /// pairs where tracking is reliable. It is compared with the mean gyroscope vector over the
  /// same interval shifted by the candidate offset.
  void add_camera_rate(double previous_frame_time, double frame_time, double rate);

  /// Centre of the search when no arrival time was given (seconds).
  void set_prior_offset(double offset) { prior_offset_ = offset; }

  ClockOffsetEstimate estimate() const;

 private:
  struct Interval {
    double begin, end, rate;  // host clock, seconds; rad/s
  };
  double mean_rate(double begin, double end) const;  // |mean gyro| over [begin, end], IMU clock
  Eigen::Vector3d integral_at(double t) const;       // integral of gyro from the first sample
  void forget_old();

  struct Gyro {
    double t;                  // IMU clock, seconds
    Eigen::Vector3d rate;      // rad/s
    Eigen::Vector3d integral;  // trapezoid integral of `rate` from the first sample kept, rad
  };
  ClockOffsetOptions options_;
  HostClockMapper arrival_;
  bool has_arrival_ = false;
  std::optional<double> prior_offset_;
  std::deque<Gyro> gyro_;
  std::deque<Interval> intervals_;
};

}  // namespace imufusion
