#include "io/imu_gate.hpp"

#include <cmath>

namespace imufusion::io {

bool ImuGate::plausible(const ImuSample& sample) const {
  if (!std::isfinite(sample.timestamp) || !sample.gyro.allFinite() || !sample.accel.allFinite()) {
    return false;
  }
  return sample.gyro.cwiseAbs().maxCoeff() <= limits_.max_gyro &&
         sample.accel.cwiseAbs().maxCoeff() <= limits_.max_accel;
}

void ImuGate::reject_held() {
  time_jumps_ += held_.size();
  held_.clear();
}

ImuVerdict ImuGate::push(const ReceivedImuSample& sample,
                         std::vector<ReceivedImuSample>* released) {
  if (!plausible(sample.sample)) {
    ++implausible_;
    return ImuVerdict::kImplausible;
  }
  const double t = sample.sample.timestamp;
  const auto continues = [&](double previous) {
    return t > previous && t - previous <= limits_.max_interval;
  };
  if (has_accepted_ && t <= last_accepted_) return ImuVerdict::kOutOfOrder;
  if (!held_.empty()) {
    const double held_last = held_.back().sample.timestamp;
    if (continues(held_last)) {
      held_.push_back(sample);
      if (held_.size() <= static_cast<std::size_t>(limits_.jump_confirmations)) {
        return ImuVerdict::kHeld;
      }
      released->insert(released->end(), held_.begin(), held_.end());
      has_accepted_ = true;
      last_accepted_ = t;
      held_.clear();
      return ImuVerdict::kAccepted;
    }
    // At the stream's start, a sample among the held ones is out of order; one well before
    // them, or after the last accepted one, says the held samples were the jump.
    if (!has_accepted_ && t <= held_last &&
        t > held_.front().sample.timestamp - limits_.max_interval) {
      return ImuVerdict::kOutOfOrder;
    }
    reject_held();
  }
  if (has_accepted_ && continues(last_accepted_)) {
    released->push_back(sample);
    last_accepted_ = t;
    return ImuVerdict::kAccepted;
  }
  if (limits_.jump_confirmations <= 0) {
    released->push_back(sample);
    has_accepted_ = true;
    last_accepted_ = t;
    return ImuVerdict::kAccepted;
  }
  held_.push_back(sample);
  return ImuVerdict::kHeld;
}

void ImuGate::finish(std::vector<ReceivedImuSample>* released) {
  if (held_.empty()) return;
  if (has_accepted_) {
    reject_held();
    return;
  }
  released->insert(released->end(), held_.begin(), held_.end());
  has_accepted_ = true;
  last_accepted_ = held_.back().sample.timestamp;
  held_.clear();
}

}  // namespace imufusion::io
