// Degrees, radians and the 180-degree period of a fiber direction (T and -T are one fiber,
// docs/models.md §1), in one place.
#pragma once
#include <algorithm>
#include <cmath>

namespace aniso {

inline constexpr double kPi = 3.14159265358979323846;

template <typename T>
constexpr T deg_to_rad(T deg) {
  return deg * T(kPi / 180.0);
}
template <typename T>
constexpr T rad_to_deg(T rad) {
  return rad * T(180.0 / kPi);
}

// An angle in radians into [0, pi): the fiber direction's period (the fit's manifold uses it).
inline double wrap_half_turn(double rad) { return rad - kPi * std::floor(rad / kPi); }

// An angle in degrees into [0, 180). A value within a micro-degree below 180 (rounding of an
// angle that is 0 modulo 180) becomes 0, so 180 is never reported.
inline double wrap_fiber_deg(double deg) {
  double w = deg - 180.0 * std::floor(deg / 180.0);
  if (w >= 180.0 - 1e-6) w = 0.0;
  return w;
}

// |a - b| modulo 180 degrees: the distance between two fiber directions, in [0, 90].
inline double fiber_deg_distance(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 180.0);
  return std::min(d, 180.0 - d);
}

}  // namespace aniso
