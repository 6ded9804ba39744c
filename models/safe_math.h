// Jet-safe helpers for the models (docs/models.md §6). Written with unqualified calls after
// `using std::...` so that ceres::Jet overloads are found by argument-dependent lookup.
#pragma once
#include <cmath>

namespace aniso {

// Below this value of 1 - a^2 the square root is replaced by its chord through (0, 0) and
// (eps, sqrt(eps)): the value stays exact at a = ±1 (sqrt = 0) and within sqrt(eps)/4 = 2.5e-7
// of sqrt everywhere, while the derivative stays below 1/sqrt(eps) = 1e6 instead of going to
// infinity. Derivatives are exact for |a| < 1 - 5e-13.
inline constexpr double kSqrtChordEps = 1e-12;

// sqrt(1 - a^2) for a in [-1, 1] (a is clamped first, docs/models.md §6).
template <class T>
T sin_from_cos(const T& a) {
  using std::sqrt;
  T x = T(1.0) - a * a;
  if (x <= T(0.0)) return T(0.0);
  if (x < T(kSqrtChordEps)) return x * (1.0 / std::sqrt(kSqrtChordEps));
  return sqrt(x);
}

// (x^+)^n, evaluated as exp(n log x) so large n neither overflows nor underflows badly;
// 0 for x <= 0 (docs/models.md §6). n >= 1 keeps the derivative in x finite at x = 0.
template <class T, class N>
T pos_pow(const T& x, const N& n) {
  using std::exp;
  using std::log;
  if (!(x > T(0.0))) return T(0.0);
  return exp(n * log(x));
}

template <class T>
T clamp_unit(const T& a) {
  if (a > T(1.0)) return T(1.0);
  if (a < T(-1.0)) return T(-1.0);
  return a;
}

}  // namespace aniso
