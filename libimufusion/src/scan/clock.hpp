#pragma once
// The wall time of a scan stage, for FrameTimings: shared by src/scan/'s .cpp files.

#include <chrono>

namespace imufusion {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace imufusion
