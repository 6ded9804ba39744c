// Gauss-Legendre nodes and weights on [-1, 1] for orders 1..kMaxGaussOrder, computed once by
// Newton iteration on the Legendre polynomials (accurate to ~1e-15).
#pragma once
#include <array>
#include <cmath>

namespace aniso {

inline constexpr int kMaxGaussOrder = 32;

struct GaussRule {
  int order = 0;
  std::array<double, kMaxGaussOrder> x{}, w{};
};

inline const GaussRule& gauss_legendre(int order) {
  static const auto rules = [] {
    std::array<GaussRule, kMaxGaussOrder + 1> r{};
    for (int n = 1; n <= kMaxGaussOrder; ++n) {
      r[n].order = n;
      for (int i = 0; i < n; ++i) {
        double x = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; ++it) {
          double p0 = 1, p1 = x;  // P_0, P_1
          for (int k = 2; k <= n; ++k) {
            const double pk = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
            p0 = p1;
            p1 = pk;
          }
          if (n == 1) p1 = x, p0 = 1;
          dp = n * (x * p1 - p0) / (x * x - 1);
          const double dx = p1 / dp;
          x -= dx;
          if (std::abs(dx) < 1e-16) break;
        }
        r[n].x[i] = x;
        r[n].w[i] = 2 / ((1 - x * x) * dp * dp);
      }
    }
    return r;
  }();
  return rules[order < 1 ? 1 : (order > kMaxGaussOrder ? kMaxGaussOrder : order)];
}

}  // namespace aniso
