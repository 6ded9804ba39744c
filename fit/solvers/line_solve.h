// fit/ internal: the plain line model's global solve without Ceres' per-block machinery: a
// hand-written Levenberg-Marquardt whose every iteration is one fused pass over the observations
// (residual, robust weight, J^T W J and J^T W r together, fit/solvers/line_pixel.h's derivatives),
// spread over threads in fixed chunks so the sums, and so the answer, do not depend on the
// scheduling. The robust loss enters by its weights rho'(|r|^2) at the current point (iteratively
// reweighted least squares inside LM): the fixed point is the minimum of sum rho(|r|^2), the
// function Ceres minimises with the same loss (the tests compare the two solvers). Ceres stays the
// fitter of record: `--solver ceres` and every other model or optional term go through it.
#pragma once
#include <vector>

#include "fit/solvers/fused_lm.h"
#include "fit/solvers/line_pixel.h"
#include "fit/solvers/model_fit.h"

namespace aniso::fitting {

using Mat8 = MatP<8>;
using Vec8 = VecP<8>;

// The eight core numbers as one vector (k_d 3, k_s 3, log n, psi) and back, and their bounds
// (models/params.h; psi free, wrapped by the solvers).
Vec8 pack_core(const Core& c);
void unpack_core(const Vec8& x, Core* c);
void core_bounds(Vec8* lo, Vec8* hi);

// Adds observations idx[begin .. end) (idx null: begin .. end themselves) at p to *s: robust cost,
// and with `jac` the channels' J^T W J and J^T W r (and, given `curv`, Huber's curvature). The one
// loop of every line-model pass.
void line_chunk(const ObsSet& os, const size_t* idx, size_t begin, size_t end,
                const LinePixelParams& p, const RobustLoss& loss, bool jac, ChannelSums<8>* s,
                HuberCurvature<8>* curv = nullptr);

// Solves from `c` (updated in place) over the observations in `subset` (null: all), at most
// `max_iterations` steps on `threads` threads; with hold_psi, psi stays where `c` has it.
void line_lm_solve(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss, double scale,
                   int max_iterations, int threads, Core* c, FusedSolve* out,
                   bool hold_psi = false);

}  // namespace aniso::fitting
