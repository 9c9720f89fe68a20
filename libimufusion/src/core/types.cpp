#include "imufusion/types.hpp"

namespace imufusion {

Intrinsics Intrinsics::at_level(int level) const {
  Intrinsics k = *this;
  const double s = 1.0 / static_cast<double>(1 << level);
  // Level-l pixel u averages level-0 pixels [2^l u, 2^l u + 2^l - 1], centred at 2^l u + (2^l-1)/2.
  k.fx = fx * s;
  k.fy = fy * s;
  k.cx = (cx + 0.5) * s - 0.5;
  k.cy = (cy + 0.5) * s - 0.5;
  k.width = width >> level;
  k.height = height >> level;
  return k;
}

}  // namespace imufusion
