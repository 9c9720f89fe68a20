#pragma once
// Paces a recording at its recorded speed: frame timestamps (seconds, the recording's clock)
// are mapped onto the steady clock from the first frame on.

#include <chrono>
#include <optional>
#include <thread>

namespace imufusion::io {

class FramePacer {
 public:
  /// Sleeps until the frame stamped `timestamp` is due.
  void wait_for(double timestamp) {
    const auto now = std::chrono::steady_clock::now();
    if (!first_) {
      first_ = timestamp;
      start_ = now;
      return;
    }
    const auto due = start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                  std::chrono::duration<double>(timestamp - *first_));
    if (due > now) std::this_thread::sleep_until(due);
  }

 private:
  std::optional<double> first_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace imufusion::io
