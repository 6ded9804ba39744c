// fit/ internal: deterministic starts. At fixed (psi, n[, topology]) every model here is linear
// in k_d and k_s, so a grid over the non-linear parameters with k_d, k_s solved in closed form at
// each node finds the basin of the global minimum without luck.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "fit/solvers/model_fit.h"

namespace aniso::fitting {

constexpr size_t kMaxStartObs = 4000;  // the start and stage 1 use at most this many pixels

// The start's second look (the global fit's, fit/global/solve.cpp; each texel's,
// fit/maps/texel_line.cpp): two valleys whose sums of squares lie within kAsWellSigma2 sigma^2 of
// each other fit the data as well. Of two fits whose predictions differ by D (the sum of squares of
// their difference), the one that is not the truth comes out lower by more than X with probability
// Phi(-(X + D) / (2 sigma sqrt(D))): at most Phi(-sqrt(X) / sigma), whatever D. At 16 sigma^2 that
// is 3e-5; at 9, 1.3e-3, which took the wrong valley on real maps (docs/solver-rules.md "Two
// valleys").
constexpr double kAsWellSigma2 = 16;

// At fixed (psi, n[, topology]) the model is linear in k_d and k_s: per channel, the 2x2
// non-negative least-squares problem on the columns (diffuse, specular) is solved in closed form
// (unconstrained, k_d only, k_s only; best non-negative). The sums of its normal equations:
struct KdKsSums {
  double dd[3] = {0, 0, 0}, ds[3] = {0, 0, 0}, ss[3] = {0, 0, 0}, dy[3] = {0, 0, 0},
         sy[3] = {0, 0, 0}, yy[3] = {0, 0, 0};
  // One observation: its diffuse and specular columns and its value.
  void add(const double dcol[3], const double scol[3], const double y[3]) {
    for (int ch = 0; ch < 3; ++ch) {
      dd[ch] += dcol[ch] * dcol[ch];
      ds[ch] += dcol[ch] * scol[ch];
      ss[ch] += scol[ch] * scol[ch];
      dy[ch] += dcol[ch] * y[ch];
      sy[ch] += scol[ch] * y[ch];
      yy[ch] += y[ch] * y[ch];
    }
  }
  // The best non-negative k_d, k_s; returns the sum of squares.
  double solve(double kd[3], double ks[3]) const;
};

// The same over `subset`, with the columns from cols(i, o) -> (diffuse, specular) for o =
// os.obs[i].
template <class Cols>
double solve_kd_ks(const ObsSet& os, const std::vector<size_t>& subset, Cols cols, double kd[3],
                   double ks[3]) {
  KdKsSums sums;
  for (size_t i : subset) {
    const Observation& o = os.obs[i];
    double dcol[3] = {0, 0, 0}, scol[3] = {0, 0, 0};
    cols(i, o, dcol, scol);
    const double y[3] = {o.y[0], o.y[1], o.y[2]};
    sums.add(dcol, scol, y);
  }
  return sums.solve(kd, ks);
}

// The line model at one grid node (psi, n = 2^log2n, x^n by squaring): k_d, k_s in closed form
// over `subset`; the sum of squares.
double line_node_cost(const ObsSet& os, const std::vector<size_t>& subset, double psi, int log2n,
                      double kd[3], double ks[3]);

// The same at `count` values of psi: four at a time where the CPU has AVX2 and FMA
// (fit/solvers/line_pixel_lanes.h; the same sums up to FMA's rounding), else node by node.
struct NodeFit {
  double cost = 0, kd[3] = {0, 0, 0}, ks[3] = {0, 0, 0};
};
// Eight nodes' KdKsSums::solve at once: out[k]'s cost, k_d and k_s from sums[k], the same bits
// (eight lanes of AVX-512 where the CPU has them, each lane the scalar form's operations in its
// order; else node by node).
void solve_kd_ks8(const KdKsSums sums[8], NodeFit out[8]);
void line_nodes_cost(const ObsSet& os, const std::vector<size_t>& subset, const double* psi,
                     int count, int log2n, NodeFit* out);

// Keeps the start strictly inside the bounds so the solver can move both ways.
void set_start_kd_ks(const double kd[3], const double ks[3], Core* c);

// Grid over psi (5 degree steps) and n (powers of 2 from 2 to 4096) with the line model's lobe
// (the fiber model's peaks sit at the same place); k_d, k_s solved at every node. With `other`:
// the best node of another valley of the grid's costs over psi (its lowest over n, 15 degrees or
// more from the best node's psi), where there is one: the start of a second look
// (fit/global/solve.cpp).
std::string line_grid_start(const ObsSet& os, Core* c, const ProgressSink* progress = nullptr,
                            std::optional<Core>* other = nullptr);

}  // namespace aniso::fitting
