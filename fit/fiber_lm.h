// fit/ internal: the fiber model's global solve by the fused Levenberg-Marquardt of
// fit/fused_lm.h (one pass per step, no Ceres machinery). A pixel's k_d and k_s enter linearly
// (r_k = base_k + sum_lights E_k (k_d[k] D + k_s[k] S) - y_k), so only D and S carry derivatives,
// by Jets of size 3 (log n, psi, the topology) through the model's interval geometry and
// quadrature, where Ceres' autodiff carries 9. Ceres stays the fitter of record (`--solver
// ceres`, and every texel-map topology); the tests compare the two.
#pragma once
#include <vector>

#include "fit/model_fit.h"
#include "models/fiber_model.h"

namespace aniso::fitting {

// Solves from `c` and `*topo` (updated; the topology is fitted unless `mode` is mathematical)
// over `subset` (null: all observations).
void fiber_lm_solve(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss, double scale,
                    int max_iterations, int threads, TopologyMode mode, const FiberAccuracy& acc,
                    Core* c, double* topo, FusedSolve* out);

}  // namespace aniso::fitting
