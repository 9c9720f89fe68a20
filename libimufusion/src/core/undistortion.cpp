#include "core/undistortion.hpp"

#include <cmath>
#include <string>

namespace imufusion {

void distort_normalized(const Intrinsics& k, double x, double y, double* xd, double* yd) {
  const auto& [k1, k2, p1, p2, k3] = k.distortion;
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  *xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  *yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
}

Result<std::vector<std::int32_t>> undistortion_sources(const Intrinsics& k) {
  static constexpr const char* kNames[5] = {"k1", "k2", "p1", "p2", "k3"};
  for (std::size_t i = 0; i < k.distortion.size(); ++i) {
    if (!std::isfinite(k.distortion[i]))
      return make_error(ErrorCode::kInvalidArgument,
                        std::string("lens distortion ") + kNames[i] + " is not finite");
  }
  std::vector<std::int32_t> sources;
  if (!k.distorted()) return sources;
  sources.resize(static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height));
  std::size_t i = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u, ++i) {
      double xd = 0, yd = 0;
      distort_normalized(k, (u - k.cx) / k.fx, (v - k.cy) / k.fy, &xd, &yd);
      const double us = std::round(k.fx * xd + k.cx), vs = std::round(k.fy * yd + k.cy);
      const bool inside = us >= 0 && vs >= 0 && us < k.width && vs < k.height;
      sources[i] =
          inside ? static_cast<std::int32_t>(vs) * k.width + static_cast<std::int32_t>(us) : -1;
    }
  }
  return sources;
}

}  // namespace imufusion
