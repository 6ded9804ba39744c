// fit/ internal: what one model contributes to a fit. The solver (fit/global/solve.cpp) knows the
// four numbers every model shares (k_d, k_s, log n, psi: docs/models.md §3) and asks the model for
// the rest: its start, its residual blocks and their bounds, its own parameter blocks for the
// covariance, the coordinates the data leave free, and its part of the material. Adding a model
// is one more implementation of ModelFit; the solver does not switch on the model.
#pragma once
#include <ceres/ceres.h>

#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fit/records/observations.h"
#include "models/line_model.h"

namespace aniso {
struct FiberAccuracy;  // models/fiber_model.h
}  // namespace aniso

namespace aniso::fitting {

// Below this fraction of the diffuse level (or absolute 1e-4) a specular lobe carries no usable
// signal: its exponent is not determined.
constexpr double kKsNegligible = 1e-4;

// The numbers every model shares, as the solver moves them.
struct Core {
  double kd[3] = {0.1, 0.1, 0.1}, ks[3] = {0.1, 0.1, 0.1};
  double logn = std::log(20.0), psi = 0.0;
};

// One of a model's own parameter blocks in the covariance: its coordinates' names (for the
// correlation matrix, empty for blocks left out of it).
struct Block {
  double* values = nullptr;
  int size = 0;
  std::vector<std::string> names;
};

// What a model's own fused solver (fit/solvers/line_solve.h) hands back.
struct FusedSolve {
  std::vector<double> info;  // J^T W J at the solution over `order` (row-major)
  // The parameter blocks of `info` (pointer, size): k_d 3, k_s 3, log n, psi and the model's own.
  std::vector<std::pair<double*, int>> order;
  double rss = 0;      // sum of w |r|^2 at the solution: the reweighted problem's residuals
  double cost = 0;     // sum of rho(|r|^2)
  int iterations = 0;  // accepted steps
  int passes = 0;      // passes over the observations
  bool converged = false;
  bool crawled = false;  // converged by the crawl rule (fused_lm.h kCrawlLeftChi2)
  // With record_costs, the cost at the start and after each accepted step (the global fit's
  // convergence, for the report; texels leave it off).
  bool record_costs = false;
  std::vector<double> costs;
};

// sigma of each coordinate of a block (already scaled by the residual variance).
using SigmaOf = std::function<std::vector<double>(const double* block, int size)>;

class ModelFit {
 public:
  virtual ~ModelFit() = default;
  Core core;
  // Set by start() where the model's grid has another valley (line_grid_start's `other`): the
  // solver settles from there too, and says where the data cannot tell the two apart.
  std::optional<Core> other;

  virtual Model model() const = 0;
  // Fitted numbers, the core's eight included.
  virtual size_t parameters() const = 0;
  // Sets the core and the model's own blocks from a deterministic grid; says which node won.
  virtual std::string start(const ObsSet& os, const ProgressSink* progress) = 0;
  // One residual block per observation in idx (loss may be null), the bounds of every block.
  virtual void add_residuals(ceres::Problem* pb, const ObsSet& os, const std::vector<size_t>& idx,
                             ceres::LossFunction* loss) = 0;
  // A faster form with the robust loss done by reweighting (sqrt_w per observation) instead of
  // by Ceres: chunks of many pixels per block. Models without one return false.
  virtual bool add_reweighted(ceres::Problem*, const ObsSet&, const std::vector<double>*) {
    return false;
  }
  // The whole solve of a stage by the model's own fused solver (fit/solvers/line_solve.h), from
  // `core`, over `subset` (null: every observation): false where the model has none or the options
  // ask for Ceres, and then nothing is changed.
  virtual bool solve_fused(const ObsSet&, const std::vector<size_t>*, FitLoss, double /*scale*/,
                           const FitOptions&, FusedSolve*) {
    return false;
  }
  // The model's own numbers beyond the core (the fiber model's topology), saved and restored
  // around the second look's settle so that each settle starts from, and keeps, its own.
  virtual std::vector<double> own() const { return {}; }
  virtual void set_own(const std::vector<double>&) {}
  // The fiber model's fitted topology value and quadrature order (for --maps; 0 otherwise).
  virtual double topology_value() const { return 0; }
  virtual int quadrature_order() const { return 0; }
  // The quadrature errors per order its choice measured (count 0: the order was given).
  virtual FiberOrderErrors quadrature_errors() const { return {}; }
  // The unweighted residual of observation i at the current parameters (for the weights).
  virtual void residual(const ObsSet&, size_t, double r[3]) const { r[0] = r[1] = r[2] = 0; }
  // Observation i's residual with its derivatives, in one evaluation where the model has them (its
  // fused solver's rows): channel k's row is nonzero at k_d[k] (dkd[k]), k_s[k] (dks[k]) and the
  // shared coordinates row_shared() names (shared[k][j]). False where the model has none (the
  // views' sandwich then differences `residual`).
  virtual bool residual_row(const ObsSet&, size_t, double /*r*/[3], double /*dkd*/[3],
                            double /*dks*/[3], double /*shared*/[3][3]) const {
    return false;
  }
  // The coordinates of residual_row's shared columns (at most 3): log n, psi, the model's own;
  // none where residual_row gives no rows.
  virtual std::vector<const double*> row_shared() const { return {}; }
  // Coordinates the data cannot fix at this solution: held constant in pb, named in res.
  virtual void hold_undetermined(ceres::Problem*, double /*kd_max*/, FitResult*) {}
  // The model's own blocks for the covariance, and whether the full correlation is wanted (not
  // for N^2 texel blocks).
  virtual std::vector<Block> blocks(ceres::Problem* pb) = 0;
  virtual bool full_correlation() const { return true; }
  virtual void sigmas(const SigmaOf& sigma, ceres::Problem* pb, FitResult* res) const = 0;
  // The model's part of the material (model, topology, optional terms) and the "fixed" notes.
  virtual void assemble(const ObsSet& os, FitResult* res) const = 0;
};

std::unique_ptr<ModelFit> make_line_fit(const FitOptions& opt);
// One pixel's residual of the plain line model with hand-written derivatives; blocks (k_d 3, k_s 3,
// log n 1, psi 1, two 1-wide blocks to hold constant).
ceres::CostFunction* line_pixel_cost(const Observation* o, const ObsLight* lights);
std::unique_ptr<ModelFit> make_fiber_fit(const FitOptions& opt, const ObsSet& os);
// One pixel's residual of the fiber model by autodiff (Ceres' reference for the fused solver);
// blocks (k_d 3, k_s 3, log n 1, psi 1, topology 1: s, A, or a constant under kMathematical).
ceres::CostFunction* fiber_pixel_cost(const ObsSet& os, size_t i, TopologyMode mode,
                                      const FiberAccuracy& acc);

// Bounds of k_d, k_s, log n from models/params.h and psi on its half-turn manifold: the blocks
// every problem shares.
void set_core_bounds(ceres::Problem* pb, Core* c);
// Bounds of a one-number block from models/params.h (log-scaled parameters in log).
void set_param_bounds(ceres::Problem* pb, double* block, int index, const char* key);

// The model parameters from the fitted blocks (k_d, k_s, log n, psi).
template <class T>
LineParamsT<T> fitted_params(const T* kd, const T* ks, const T* logn, const T* psi) {
  using std::exp;
  LineParamsT<T> p;
  for (int k = 0; k < 3; ++k) {
    p.kd[k] = kd[k];
    p.ks[k] = ks[k];
  }
  p.n = exp(logn[0]);
  p.psi = psi[0];
  return p;
}

// residual = sum over the pixel's lights of E * reflectance(L, V) - y.
template <class T, class Reflectance>
void pixel_residual(const Observation* obs, const ObsLight* lights, Reflectance reflectance, T* r) {
  T acc[3] = {T(0.0), T(0.0), T(0.0)};
  for (uint32_t i = 0; i < obs->num_lights; ++i) {
    const ObsLight& l = lights[obs->first_light + i];
    T f[3];
    reflectance(l.L, obs->V, f);
    for (int k = 0; k < 3; ++k) acc[k] += double(l.E[k]) * f[k];
  }
  for (int k = 0; k < 3; ++k) r[k] = acc[k] - double(obs->y[k]);
}

}  // namespace aniso::fitting
