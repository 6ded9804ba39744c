// fit/ internal: deterministic starts. At fixed (psi, n[, topology]) every model here is linear
// in k_d and k_s, so a grid over the non-linear parameters with k_d, k_s solved in closed form at
// each node finds the basin of the global minimum without luck.
#pragma once
#include <string>
#include <vector>

#include "fit/model_fit.h"

namespace aniso::fitting {

constexpr size_t kMaxStartObs = 4000;  // the start and stage 1 use at most this many pixels

// At fixed (psi, n[, topology]) the model is linear in k_d and k_s: per channel, the 2x2
// non-negative least-squares problem on the columns cols(o) -> (diffuse, specular) is solved in
// closed form (unconstrained, k_d only, k_s only; best non-negative). Returns the sum of squares.
template <class Cols>
double solve_kd_ks(const ObsSet& os, const std::vector<size_t>& subset, Cols cols, double kd[3],
                   double ks[3]) {
  double dd[3] = {0, 0, 0}, ds[3] = {0, 0, 0}, ss[3] = {0, 0, 0}, dy[3] = {0, 0, 0},
         sy[3] = {0, 0, 0}, yy[3] = {0, 0, 0};
  for (size_t i : subset) {
    const Observation& o = os.obs[i];
    double dcol[3] = {0, 0, 0}, scol[3] = {0, 0, 0};
    cols(o, dcol, scol);
    for (int ch = 0; ch < 3; ++ch) {
      const double y = o.y[ch] - o.base[ch];
      dd[ch] += dcol[ch] * dcol[ch];
      ds[ch] += dcol[ch] * scol[ch];
      ss[ch] += scol[ch] * scol[ch];
      dy[ch] += dcol[ch] * y;
      sy[ch] += scol[ch] * y;
      yy[ch] += y * y;
    }
  }
  double cost = 0;
  for (int ch = 0; ch < 3; ++ch) {
    auto sse = [&](double a, double b) {
      return yy[ch] - 2 * a * dy[ch] - 2 * b * sy[ch] + a * a * dd[ch] + 2 * a * b * ds[ch] +
             b * b * ss[ch];
    };
    double ba = 0, bb = 0, bc = sse(0, 0);
    const double det = dd[ch] * ss[ch] - ds[ch] * ds[ch];
    if (det > 1e-300) {
      const double a = (dy[ch] * ss[ch] - sy[ch] * ds[ch]) / det,
                   b = (sy[ch] * dd[ch] - dy[ch] * ds[ch]) / det;
      if (a >= 0 && b >= 0 && sse(a, b) < bc) ba = a, bb = b, bc = sse(a, b);
    }
    if (dd[ch] > 0) {
      const double a = std::max(dy[ch] / dd[ch], 0.0);
      if (sse(a, 0) < bc) ba = a, bb = 0, bc = sse(a, 0);
    }
    if (ss[ch] > 0) {
      const double b = std::max(sy[ch] / ss[ch], 0.0);
      if (sse(0, b) < bc) ba = 0, bb = b, bc = sse(0, b);
    }
    kd[ch] = ba;
    ks[ch] = bb;
    cost += bc;
  }
  return cost;
}

// The line model at one grid node (psi, n): k_d, k_s in closed form over `subset`; the sum of
// squares.
double line_node_cost(const ObsSet& os, const std::vector<size_t>& subset, double psi, double n,
                      double kd[3], double ks[3]);

// Keeps the start strictly inside the bounds so the solver can move both ways.
void set_start_kd_ks(const double kd[3], const double ks[3], Core* c);

// Grid over psi (5 degree steps) and n (powers of 2 from 2 to 4096) with the line model's lobe
// (the fiber model's peaks sit at the same place); k_d, k_s solved at every node.
std::string line_grid_start(const ObsSet& os, Core* c, bool progress = false);

}  // namespace aniso::fitting
