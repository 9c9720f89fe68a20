#pragma once
// Live inputs of imufusion-scan: IMU samples streamed over UDP and mapped onto the frame clock,
// and the session recorder. Clocks (seconds): the IMU's own clock, the host clock
// (host_clock_now()) and the frame clock (the source's timestamps: the host clock for live
// cameras, the recording's clock for sequences and .oni files). Both sensors are mapped onto
// the host clock from arrival times; the IMU's offset onto the frame clock is their difference:
//
//   t_frame = t_imu + imu_offset - frame_offset,  t_host = t_x + x_offset.

#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "imufusion/clock_offset.hpp"
#include "imufusion/imu_stream.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/recorder.hpp"

namespace imufusion::tools {

inline const char* to_string(ClockOffsetEstimate::Source source) {
  switch (source) {
    case ClockOffsetEstimate::Source::kArrival:
      return "arrival";
    case ClockOffsetEstimate::Source::kCorrelation:
      return "correlation";
    case ClockOffsetEstimate::Source::kNone:
      break;
  }
  return "none";
}

/// The UDP IMU stream of a scan: polled once per frame, samples handed out on the frame clock.
class LiveImu {
 public:
  static Result<LiveImu> open(std::uint16_t port, const std::string& address) {
    ImuUdpOptions options;
    options.port = port;
    options.address = address;
    auto listener = ImuUdpListener::open(options);
    if (!listener) return listener.error();
    return LiveImu(std::move(*listener));
  }

  std::string endpoint() const { return listener_.endpoint(); }

  /// Called when a frame arrives (before tracking it): records its arrival, takes the samples
  /// received since the previous frame and returns them on the frame clock. `raw` gets them
  /// on the IMU clock (for the recorder).
  std::vector<ImuSample> take(double frame_time, std::vector<ImuSample>* raw) {
    frame_clock_.observe(host_clock_now(), frame_time);
    raw->clear();
    for (const ReceivedImuSample& r : listener_.take_samples()) {
      estimator_.add_imu(r.sample, r.host_receive_time);
      raw->push_back(r.sample);
    }
    // The correlation search costs O(lags x intervals x log n) (milliseconds over a 30 s
    // history): once it has an answer it is refreshed every kCorrelationRefreshFrames frames;
    // the arrival-time offset it falls back on is refreshed every frame.
    if (estimate_.source != ClockOffsetEstimate::Source::kCorrelation ||
        ++frames_since_estimate_ >= kCorrelationRefreshFrames) {
      estimate_ = estimator_.estimate();
      frames_since_estimate_ = 0;
    }
    // A smaller offset than the last frame's maps new samples before ones already delivered:
    // those overlap what the scan has, and are left out (counted) to keep the stream in order.
    const double offset = imu_to_frame_offset();
    std::vector<ImuSample> mapped;
    for (ImuSample s : *raw) {
      s.timestamp += offset;
      if (last_mapped_ && s.timestamp <= *last_mapped_) {
        ++overlapping_;
        continue;
      }
      last_mapped_ = s.timestamp;
      mapped.push_back(s);
    }
    return mapped;
  }

  /// Feeds the camera's rotation rate between consecutive reliably tracked frames to the
  /// correlation estimate of the clock offset.
  void observe(const FrameResult& frame) {
    const bool reliable =
        frame.icp_ran && frame.icp.reliable() && frame.status == TrackingStatus::kTracking;
    if (reliable && previous_ && frame.timestamp > previous_->first) {
      const Eigen::AngleAxisd turn(previous_->second.linear().transpose() *
                                   frame.T_world_camera.linear());
      const double frame_offset = frame_clock_.offset().value_or(0.0);
      estimator_.add_camera_rate(previous_->first + frame_offset, frame.timestamp + frame_offset,
                                 std::abs(turn.angle()) / (frame.timestamp - previous_->first));
    }
    if (reliable || !previous_) {
      previous_ = std::pair{frame.timestamp, frame.T_world_camera};
    } else {
      previous_.reset();
    }
  }

  /// t_frame = t_imu + this (seconds).
  double imu_to_frame_offset() const {
    return estimate_.offset - frame_clock_.offset().value_or(0.0);
  }

  nlohmann::json report() const {
    const ImuStreamStats s = listener_.stats();
    nlohmann::json j;
    j["endpoint"] = listener_.endpoint();
    j["datagrams"] = s.datagrams;
    j["samples"] = s.samples;
    j["malformed"] = s.malformed;
    j["incomplete"] = s.incomplete;
    j["out_of_order"] = s.out_of_order;
    j["implausible"] = s.implausible;
    j["time_jumps"] = s.time_jumps;
    j["overflow"] = s.overflow;
    if (s.first_malformed) j["first_malformed"] = *s.first_malformed;
    j["clock_offset_source"] = to_string(estimate_.source);
    j["clock_offset_host_s"] = estimate_.offset;
    j["clock_offset_frame_s"] = imu_to_frame_offset();
    j["clock_offset_confidence"] = estimate_.confidence;
    j["clock_offset_standard_error_s"] = estimate_.standard_error;
    j["clock_offset_correlation_host_s"] = estimate_.correlation_offset;
    j["clock_offset_intervals"] = estimate_.intervals;
    j["left_out_by_offset_change"] = overlapping_;
    return j;
  }

 private:
  explicit LiveImu(ImuUdpListener listener) : listener_(std::move(listener)) {}

  ImuUdpListener listener_;
  ClockOffsetEstimator estimator_;
  HostClockMapper frame_clock_;
  ClockOffsetEstimate estimate_;
  static constexpr int kCorrelationRefreshFrames =
      30;  // ~1 s at 30 Hz; the offset drifts far slower
  int frames_since_estimate_ = 0;
  std::optional<double> last_mapped_;  // frame-clock time of the last sample delivered (s)
  std::size_t overlapping_ = 0;        // samples left out for a decreased offset
  std::optional<std::pair<double, Eigen::Isometry3d>>
      previous_;  // last reliable frame: time, T_world_camera
};

inline nlohmann::json recorder_report(const SessionRecorder& recorder, const Status& finished) {
  const RecorderStats s = recorder.stats();
  nlohmann::json j;
  j["directory"] = recorder.directory().string();
  j["frames_queued"] = s.frames_queued;
  j["frames_written"] = s.frames_written;
  j["frames_dropped"] = s.frames_dropped;
  j["imu_samples"] = s.imu_samples;
  j["imu_dropped"] = s.imu_dropped;
  if (!finished) j["error"] = finished.error().describe();
  return j;
}

/// The status line's tracking state: "tracking", "dead reckoning" or "recovering".
inline const char* tracking_state(const FrameResult& f) {
  if (f.status == TrackingStatus::kRecovering) return "recovering";
  if (f.status == TrackingStatus::kLost || f.source == PoseSource::kDeadReckoning)
    return "dead reckoning";
  return "tracking";
}

}  // namespace imufusion::tools
