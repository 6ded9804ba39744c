// Brute-force reference for the fiber model (docs/models.md §4), independent of
// models/fiber_model.h: dense midpoint sampling of the normal angle on one period, plain ray-circle
// intersection tests against every nearby fiber copy, no interval algebra, no closed forms.
#pragma once
#include <cmath>
#include <vector>

namespace aniso::reference {

struct Circle {
  double x, y;
};

// Does the ray p + t d (t > 0) hit a unit circle centred at c?
inline bool ray_hits(double px, double py, double dx, double dy, const Circle& c) {
  const double ox = px - c.x, oy = py - c.y;
  const double b = ox * dx + oy * dy, cc = ox * ox + oy * oy - 1.0;
  const double disc = b * b - cc;
  if (disc <= 0) return false;
  const double t = -b + std::sqrt(disc);  // far root; the near root -b - sqrt
  const double t0 = -b - std::sqrt(disc);
  constexpr double kEps = 1e-9;  // leaving the own surface
  return t > kEps && t0 > kEps;
}

struct Result {
  double D = 0, S = 0, W = 0;
};

// `samples` normal angles per fiber; `plane` replaces the fibers by a flat plane (identity 4).
inline Result fiber_bruteforce(double lb, double ln, double vb, double vn, double a, double b,
                               double n, double s, int samples, bool plane = false) {
  Result r;
  if (ln <= 0 || vn <= 0) return r;
  const double sL = std::hypot(lb, ln), sV = std::hypot(vb, vn);
  const double lx = lb / sL, ly = ln / sL, vx = vb / sV, vy = vn / sV;
  const double LdotV = a * b + sL * sV * (lx * vx + ly * vy);
  if (plane) {  // normal (0, 1) everywhere; width element v_y dx over one unit of x
    const double nl = sL * ly, nv = sV * vy;
    const double rv = 2 * nl * nv - LdotV;
    r.W = vy;
    r.D = nl;
    r.S = rv > 0 ? std::pow(rv, n) : 0.0;
    return r;
  }
  const double th = M_PI / 3 * s, P = 4 * std::cos(th), H = 2 * std::sin(th);
  std::vector<Circle> all;
  const int K = 2 + static_cast<int>(std::ceil(4.0 / (P * std::min(vy, ly))));
  for (int k = -K; k <= K; ++k) {
    all.push_back({k * P, 0});
    all.push_back({k * P + P / 2, H});
  }
  const Circle own[2] = {{0, 0}, {P / 2, H}};
  const double dphi = 2 * M_PI / samples;
  for (int f = 0; f < 2; ++f)
    for (int i = 0; i < samples; ++i) {
      const double phi = -M_PI + (i + 0.5) * dphi;
      const double nx = std::sin(phi), ny = std::cos(phi);
      const double cv = nx * vx + ny * vy, cl = nx * lx + ny * ly;
      if (cv <= 0) continue;
      const double px = own[f].x + nx, py = own[f].y + ny;
      bool hidden = false;
      for (const auto& c : all)
        if (!(c.x == own[f].x && c.y == own[f].y) && ray_hits(px, py, vx, vy, c)) {
          hidden = true;
          break;
        }
      if (hidden) continue;
      r.W += cv * dphi;
      if (cl <= 0) continue;
      bool shadowed = false;
      for (const auto& c : all)
        if (!(c.x == own[f].x && c.y == own[f].y) && ray_hits(px, py, lx, ly, c)) {
          shadowed = true;
          break;
        }
      if (shadowed) continue;
      const double nL = sL * cl, nV = sV * cv;
      const double rv = 2 * nL * nV - LdotV;
      r.D += nL * cv * dphi;
      if (rv > 0) r.S += std::pow(rv, n) * cv * dphi;
    }
  if (r.W > 0) {
    r.D /= r.W;
    r.S /= r.W;
  }
  return r;
}

}  // namespace aniso::reference
