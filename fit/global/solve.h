// fit/ internal: one interface over the solve paths (per-pixel blocks with Ceres' robust loss,
// or the model's chunked form with the loss by reweighting). The problem is kept for the
// covariance (fit/global/uncertainty.cpp).
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fit/solvers/model_fit.h"

namespace aniso::fitting {

struct Solution {
  // The Ceres problem at the solution; null when the model's fused solver found it, which hands
  // J^T W J at the solution instead (`information`, row-major over the blocks of
  // `information_order`: k_d, k_s, log n, psi and the model's own).
  std::unique_ptr<ceres::Problem> problem;
  std::vector<double> information;
  std::vector<std::pair<double*, int>> information_order;
  ceres::Solver::Summary summary;
  std::vector<double> sqrt_w;  // reweighting weights: the problem's blocks point at them
  double rss = 0;              // of the final problem's residuals
  double values = 0;           // measured values: pixels x channels (x 1 for grey)
  double weights_change = 0;   // reweighting: the largest change of a weight in its last round
  // Where another fiber direction fits the data as well (the start's second look): what it is.
  std::string other_minimum;
  bool misfit = false;  // the model does not describe the data (the misfit warning was given)
};

// Starts the model, solves, and fills the report's start, noise, loss, iterations, RMS, BIC,
// timings and misfit warning. The model's blocks hold the solution.
Solution solve(ModelFit* m, const ObsSet& os, const FitOptions& opt, FitReport* rep);

// The global fit's Ceres options (--max-iterations, --threads, each iteration on a terminal).
ceres::Solver::Options solver_options(const FitOptions& opt);

// The robust loss of --loss at the given scale (null for none).
ceres::LossFunction* make_loss(FitLoss loss, double scale);

// Does the model describe the data? The warning to give where the residual RMS of `rep` is well
// above the images' noise (or the residuals' robust sigma for tables), else "".
std::string misfit_warning(const ObsSet& os, const FitReport& rep);

// The start's second look: settled from the other valley of the start's grid too (m->other), the
// fit goes on from the lower of the two; where the whole set would not tell them apart (their sums
// of squares on the subset, scaled to the whole set's pixels, within kAsWellSigma2), the other is
// said. Without it, a set that cannot tell psi from -psi (every view and light in one plane
// through the normal: an in-plane gonioreflectometer) gave psi = 150 deg with sigma 4e-7 deg
// for a truth of 30 deg, without a word; the fiber model 150.04 deg +- 0.05 deg. Both settles
// start from the model's own numbers of the start (start_own: the fiber model's topology), and
// the one taken keeps its own. *r: the residuals of the first settle (m at its
// solution), then of the one taken; `pixels` of which `subset` were settled. Returns the message
// naming the other where the two fit as well, else "".
std::string second_look(ModelFit* m, const std::vector<double>& start_own, size_t pixels,
                        size_t subset, bool grey,
                        const std::function<std::vector<double>()>& settle, std::vector<double>* r,
                        FitReport* rep);

// sigma, undetermined and the correlation matrix of every fitted number (docs/models.md §6).
void estimate_uncertainty(ModelFit* m, const ObsSet& os, const FitOptions& opt, Solution* sol,
                          FitResult* res);

}  // namespace aniso::fitting
