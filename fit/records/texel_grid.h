// fit/ records: the texel grid of --maps, as observations are binned and tiles banded.
#pragma once

namespace aniso::fitting {

// The texel of (u, v) on a w x h grid (row-major; texel (i, j) covers u in [i/w, (i+1)/w)), or -1
// where uv lies outside [0, 1)^2. The one rule that bins observations and bands tiles.
inline long texel_of(double u, double v, int w, int h) {
  if (!(u >= 0 && u < 1 && v >= 0 && v < 1)) return -1;
  return static_cast<long>(v * h) * w + static_cast<long>(u * w);
}

}  // namespace aniso::fitting
