#pragma once
// Paces a recording at its recorded speed: frame timestamps (seconds, the recording's clock)
// are mapped onto the steady clock from the first frame on.

#include <chrono>
#include <optional>
#include <thread>

namespace imufusion::io {

class FramePacer {
 public:
  using Clock = std::chrono::steady_clock;

  /// When the frame stamped `timestamp`, read at `now`, is due: the first frame at once (it
  /// anchors the schedule), every later one at the first one's time plus the recorded interval
  /// since it. A frame read late is due in the past; the schedule does not move.
  Clock::time_point due(double timestamp, Clock::time_point now) {
    if (!first_) {
      first_ = timestamp;
      start_ = now;
    }
    return start_ + std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double>(timestamp - *first_));
  }

  /// Sleeps until the frame stamped `timestamp` is due.
  void wait_for(double timestamp) {
    const auto now = Clock::now();
    const auto at = due(timestamp, now);
    if (at > now) std::this_thread::sleep_until(at);
  }

 private:
  std::optional<double> first_;
  Clock::time_point start_;
};

}  // namespace imufusion::io
