// fit/ internal: the fiber model's global solve by the fused Levenberg-Marquardt of
// fit/solvers/fused_lm.h (one pass per step, no Ceres machinery). A pixel's k_d and k_s enter
// linearly (r_k = base_k + sum_lights E_k (k_d[k] D + k_s[k] S) - y_k), so only D and S carry
// derivatives, by Jets of size 3 (log n, psi, the topology) through the model's interval geometry
// and quadrature, where Ceres' autodiff carries 9. Ceres stays the fitter of record (`--solver
// ceres`, and every texel-map topology); the tests compare the two.
#pragma once
#include <vector>

#include "fit/solvers/model_fit.h"
#include "models/fiber_model.h"

namespace aniso::fitting {

// The pixel's D and S summed over its lights with their irradiance, per channel (dcol, scol: the
// columns that k_d and k_s multiply), at psi (cos c, sin sn), exponent n and topology s.
inline void fiber_columns(const ObsSet& os, const Observation& o, double c, double sn, double n,
                          double s, const FiberAccuracy& acc, double dcol[3], double scol[3]) {
  const double b = c * o.V.u + sn * o.V.w, vb = c * o.V.w - sn * o.V.u;
  for (uint32_t q = 0; q < o.num_lights; ++q) {
    const ObsLight& l = os.lights[o.first_light + q];
    const LocalDir L = l.L;
    double D, S;
    fiber_DS(c * L.w - sn * L.u, L.n, vb, double(o.V.n), c * L.u + sn * L.w, b, n, s, acc, &D, &S);
    for (int ch = 0; ch < 3; ++ch) {
      dcol[ch] += l.E[ch] * D;
      scol[ch] += l.E[ch] * S;
    }
  }
}

// Observation i's residual and its rows as the fused solve's pass makes them (shared columns:
// log n, psi and, unless the topology is the mathematical one, the topology `topo`).
void fiber_row(const ObsSet& os, size_t i, TopologyMode mode, const FiberAccuracy& acc,
               const Core& c, double topo, double r[3], double dkd[3], double dks[3],
               double shared[3][3]);

// A quadratic pull of the solve's numbers (k_d 3, k_s 3, log n, psi, the topology) toward b with
// weights w, psi's difference taken modulo a half turn: --smooth for the fiber model's texels.
struct FiberPull {
  double w[9] = {}, b[9] = {};
};

// Solves from `c` and `*topo` (updated; the topology is fitted unless `mode` is mathematical)
// over `subset` (null: all observations). With `pull`, its terms join the cost of every step;
// out->info and out->rss are then still the data's own (the pull taken out at the solution).
// `ridge_rule`: a texel's solve, done on a ridge of k_s and n (fit/solvers/fused_lm.h
// kRidgeIterations). `lambda0`: the first step's damping (0: fused_lm's own). `progress`: each pass
// over the observations said as its status line (the global fit's: seconds each on a large set).
void fiber_lm_solve(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss, double scale,
                    int max_iterations, int threads, TopologyMode mode, const FiberAccuracy& acc,
                    Core* c, double* topo, FusedSolve* out, const FiberPull* pull = nullptr,
                    bool ridge_rule = false, double lambda0 = 0,
                    const ProgressSink* progress = nullptr);

}  // namespace aniso::fitting
