// The sRGB transfer function (IEC 61966-2-1) in one place: encoding for 8-bit outputs, decoding
// for images a capture states are sRGB.
#pragma once
#include <algorithm>
#include <cmath>

namespace aniso {

// Linear [0, 1] -> sRGB code value [0, 1] (input clamped).
inline double srgb_encode(double v) {
  v = std::clamp(v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
}

// sRGB code value -> linear; odd-symmetric so a value below the black level keeps its sign.
inline double srgb_decode(double v) {
  const double a = std::abs(v);
  const double l = a <= 0.04045 ? a / 12.92 : std::pow((a + 0.055) / 1.055, 2.4);
  return v < 0 ? -l : l;
}

}  // namespace aniso
