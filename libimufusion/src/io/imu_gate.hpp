#pragma once
// The check every IMU sample passes before it is used, from imu.txt or from the UDP stream
// alike: rates and forces a real sensor can measure (ImuSampleLimits), time after the previous
// sample, and no jump in time that the samples after it do not confirm.

#include <cstddef>
#include <vector>

#include "imufusion/imu_stream.hpp"

namespace imufusion::io {

/// What became of one sample passed to ImuGate::push.
enum class ImuVerdict {
  kAccepted,     // released now (with any held samples before it)
  kHeld,         // after a jump in time or at the stream's start: waits for confirmation
  kImplausible,  // beyond the limits, or NaN/inf: rejected
  kOutOfOrder,   // not after the last accepted sample: rejected
};

class ImuGate {
 public:
  explicit ImuGate(const ImuSampleLimits& limits) : limits_(limits) {}

  /// Checks `sample`; appends every sample it releases (held ones first, in order) to
  /// `released`. Samples held before are rejected as time jumps when the stream goes on from
  /// before them.
  ImuVerdict push(const ReceivedImuSample& sample, std::vector<ReceivedImuSample>* released);
  /// The end of the stream: held samples are released when nothing was accepted before them
  /// (a stream too short to confirm), otherwise rejected as a jump.
  void finish(std::vector<ReceivedImuSample>* released);

  bool has_accepted() const { return has_accepted_; }
  /// The newest sample taken, held or accepted (seconds); what a sample out of order is not after.
  double latest() const { return held_.empty() ? last_accepted_ : held_.back().sample.timestamp; }
  std::size_t implausible() const { return implausible_; }
  std::size_t time_jumps() const { return time_jumps_; }

 private:
  bool plausible(const ImuSample& sample) const;
  void reject_held();

  ImuSampleLimits limits_;
  std::vector<ReceivedImuSample> held_;
  bool has_accepted_ = false;
  double last_accepted_ = 0;
  std::size_t implausible_ = 0;
  std::size_t time_jumps_ = 0;
};

}  // namespace imufusion::io
