// A material at one point of a sample with maps (docs/formats.md "Material maps"): texel (i, j) has
// its centre at ((i + 1/2)/W, (j + 1/2)/H); lookups are bilinear, clamped at the border or
// repeated. The fiber map holds the doubled angle, so directions equal modulo 180 degrees
// interpolate right.
#pragma once
#include <cmath>

#include "core/texture.h"
#include "models/material.h"

namespace aniso {

// Bilinear lookup of channel c of `img` at (u, v) (core/texture.h's taps).
inline double map_lookup(const Image& img, double u, double v, int c, bool repeat) {
  const BilinearTaps t = bilinear_taps(u, v, img.width, img.height, repeat);
  double s = 0;
  for (int k = 0; k < 4; ++k)
    s += t.weight[k] * img.px[static_cast<size_t>(t.index[k]) * img.channels + c];
  return s;
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
  if (auto* t = out.topology_as<TopologyMapRef>(); t && mp.amplitude)
    t->amplitude = map_lookup(*mp.amplitude, u, v, 0, mp.repeat);
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
