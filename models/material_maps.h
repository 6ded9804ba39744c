// A material at one point of a sample with maps (FORMAT.md "Material maps"): texel (i, j) has its
// centre at ((i + 1/2)/W, (j + 1/2)/H); lookups are bilinear, clamped at the border or repeated.
// The fiber map holds the doubled angle, so directions equal modulo 180 degrees interpolate right.
#pragma once
#include <algorithm>
#include <cmath>

#include "models/material.h"

namespace aniso {

// Bilinear lookup of channel c of `img` at (u, v).
inline double map_lookup(const Image& img, double u, double v, int c, bool repeat) {
  const double x = u * img.width - 0.5, y = v * img.height - 0.5;
  const double fx = std::floor(x), fy = std::floor(y), tx = x - fx, ty = y - fy;
  auto idx = [&](long i, int n) {
    if (repeat) return static_cast<int>(((i % n) + n) % n);
    return static_cast<int>(std::clamp<long>(i, 0, n - 1));
  };
  const int x0 = idx(static_cast<long>(fx), img.width),
            x1 = idx(static_cast<long>(fx) + 1, img.width);
  const int y0 = idx(static_cast<long>(fy), img.height),
            y1 = idx(static_cast<long>(fy) + 1, img.height);
  return (1 - tx) * (1 - ty) * img.at(x0, y0, c) + tx * (1 - ty) * img.at(x1, y0, c) +
         (1 - tx) * ty * img.at(x0, y1, c) + tx * ty * img.at(x1, y1, c);
}

// The material with every map sampled at (u, v); without maps, the material itself.
inline Material material_at(const Material& m, double u, double v) {
  Material out = m;
  const MaterialMaps& mp = m.maps;
  if (!mp.any()) return out;
  out.maps = MaterialMaps{};
  for (int c = 0; c < 3; ++c) {
    if (mp.kd) out.kd[c] = map_lookup(*mp.kd, u, v, mp.kd->channels == 1 ? 0 : c, mp.repeat);
    if (mp.ks) out.ks[c] = map_lookup(*mp.ks, u, v, mp.ks->channels == 1 ? 0 : c, mp.repeat);
  }
  if (mp.n) out.n = map_lookup(*mp.n, u, v, 0, mp.repeat);
  if (mp.fiber) {
    const double c2 = map_lookup(*mp.fiber, u, v, 0, mp.repeat);
    const double s2 = map_lookup(*mp.fiber, u, v, 1, mp.repeat);
    double deg = 0.5 * std::atan2(s2, c2) * 180.0 / M_PI;
    if (deg < 0) deg += 180;
    out.fiber_angle_deg = deg;
  }
  return out;
}

}  // namespace aniso
