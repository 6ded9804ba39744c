// The solve, whatever the model (docs/models.md §6): a start from the model's grid, stage 1 (plain
// least squares on a subset, to settle and to measure the noise), stage 2 (every observation
// with the robust loss: by Ceres' loss, or by reweighting where the model has a chunked form),
// then the summary numbers and the misfit check.
#include "fit/global/solve.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>

#include "core/angles.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/timer.h"
#include "fit/solvers/crawl.h"
#include "fit/solvers/line_pixel_lanes.h"
#include "fit/solvers/start.h"
#include "models/params.h"

namespace aniso::fitting {

namespace {

using Clock = SteadyClock;

// psi lives on the circle of period pi (the model is unchanged under T -> -T, docs/models.md §1).
class HalfTurnManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 1; }
  int TangentSize() const override { return 1; }
  bool Plus(const double* x, const double* delta, double* y) const override {
    y[0] = wrap(x[0] + delta[0]);
    return true;
  }
  bool PlusJacobian(const double*, double* j) const override {
    j[0] = 1.0;
    return true;
  }
  bool Minus(const double* y, const double* x, double* d) const override {
    double v = wrap(y[0] - x[0]);
    if (v > M_PI / 2) v -= M_PI;
    d[0] = v;
    return true;
  }
  bool MinusJacobian(const double*, double* j) const override {
    j[0] = 1.0;
    return true;
  }
  static double wrap(double a) { return wrap_half_turn(a); }
};

// Each solver iteration as the progress sink's status line.
class IterationStatus : public ceres::IterationCallback {
 public:
  explicit IterationStatus(const ProgressSink* sink) : sink_(sink) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    char line[120];
    std::snprintf(line, sizeof line, "fit: iteration %3d, cost %.6g, step %.3g", s.iteration,
                  s.cost, s.step_norm);
    sink_->status(line);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const ProgressSink* sink_;
};

// The callback of a sink (one per sink for the process's life: Ceres' options hold a pointer).
ceres::IterationCallback* iteration_status(const ProgressSink* sink) {
  static std::mutex mu;
  static std::map<const ProgressSink*, std::unique_ptr<IterationStatus>> made;
  std::lock_guard<std::mutex> lock(mu);
  auto& c = made[sink];
  if (!c) c = std::make_unique<IterationStatus>(sink);
  return c.get();
}

// fused_lm.h's crawl rule for a Ceres solve: every kCrawlWindow successful steps the cost's fall is
// compared with the window's before, and the solve ends where the geometric rest of the falls is
// under kCrawlLeftChi2 (Ceres' cost is half the sum of rho: twice its falls are the sums'; the
// residual variance from the cost itself, 2 cost / (values - parameters), which under a robust
// loss is smaller than the squares' and so stops later).
class CrawlStop : public ceres::IterationCallback {
 public:
  CrawlStop(double values, size_t parameters)
      : dof_(std::max(1.0, values - static_cast<double>(parameters))) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (s.iteration == 0) watch_ = CrawlWatch(2 * s.cost);
    if (s.iteration == 0 || !s.step_is_successful) return ceres::SOLVER_CONTINUE;
    crawled = watch_.accepted(2 * s.cost, 2 * s.cost / dof_);
    return crawled ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }
  bool crawled = false;

 private:
  double dof_;
  CrawlWatch watch_{0};
};

}  // namespace

ceres::Solver::Options solver_options(const FitOptions& opt) {
  ceres::Solver::Options so;
  if (opt.progress) so.callbacks.push_back(iteration_status(opt.progress));
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // at most 17 parameters
  so.max_num_iterations = opt.max_iterations;
  so.num_threads = std::max(1, opt.threads);
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  return so;
}

ceres::LossFunction* make_loss(FitLoss loss, double scale) {
  switch (loss) {
    case FitLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case FitLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case FitLoss::kNone:
      break;
  }
  return nullptr;
}

// Does the model describe the data? The residual RMS of a model that fits is about the noise of
// the images (neighbouring pixels tell it, whatever the model); a systematic misfit makes it
// larger. Without images (tables) the robust sigma of the residuals stands in. Noise-free data
// has no noise to compare with: there a misfit below 1e-4 of the signal counts as a fit.
// Returns the warning to give, or "".
std::string misfit_warning(const ObsSet& os, const FitReport& rep) {
  double signal = 0;
  for (const auto& o : os.obs) signal += std::abs(o.y[0]) + std::abs(o.y[1]) + std::abs(o.y[2]);
  signal /= std::max<double>(1.0, 3.0 * static_cast<double>(os.obs.size()));
  constexpr double kMisfitRatio = 2.0, kNoiseFreeFloor = 1e-4;
  const double noise = os.pixel_noise > 0 ? os.pixel_noise : rep.noise_sigma;
  if (!(rep.rms > kMisfitRatio * std::max(noise, kNoiseFreeFloor * signal))) return "";
  char buf[1280];
  std::snprintf(
      buf, sizeof buf,
      "the model does not describe the data: residual RMS %.3g is %.1fx the noise of "
      "the images %.3g. Likely causes: %sa material that varies over the sample (brushed "
      "in swirls, woven in regions: fit maps with --maps WxH), a second fiber direction "
      "(woven cloth: --fit-second-fiber), an isotropic term (--fit-isotropic), shadows or "
      "interreflections, a wrong exposure or color.encoding, hot pixels. Check "
      "`aniso verify CAPTURE MATERIAL --residuals DIR`.",
      rep.rms, rep.rms / std::max(noise, 1e-300), noise,
      // A photo shoot's own errors first: they show as a misfit before the material does.
      os.from_shoot ? "the shoot (lamps kept as written or far from where import_report.json "
                      "found them, board.square_m not the printed square's size, the sample's "
                      "polygon_m or height_m, the calibration's RMS; a smooth gradient across "
                      "`aniso verify`'s residual images is a lamp or calibration error), then "
                    : "");
  return buf;
}

namespace {

// Adds one round's summary to the running one (iterations, evaluations, termination).
void accumulate(const ceres::Solver::Summary& round, bool first, ceres::Solver::Summary* sum) {
  sum->iterations.insert(sum->iterations.end(), round.iterations.begin() + (first ? 0 : 1),
                         round.iterations.end());
  sum->num_residual_evaluations += round.num_residual_evaluations;
  sum->num_jacobian_evaluations += round.num_jacobian_evaluations;
  sum->termination_type = round.termination_type;
  sum->message = round.message;
}

std::unique_ptr<ceres::Problem> new_problem() {
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::TAKE_OWNERSHIP;
  return std::make_unique<ceres::Problem>(po);
}

// Robust loss by iteratively reweighted least squares: per pixel w = rho'(|r|^2) of the loss
// Ceres would apply, re-solved until the weights settle (at most kIrlsRounds; sol->weights_change
// says by how much they last moved). False if the model has no reweighted form. The rounds converge
// linearly where many pixels lie outside the loss's core: settled at 1e-4, psi is ~0.01 sigma from
// the minimum (docs/solver-rules.md "The reweighted rounds").
constexpr int kIrlsRounds = 30;
constexpr double kWeightsSettled = 1e-4;

bool solve_reweighted(ModelFit* m, const ObsSet& os, const FitOptions& opt,
                      const ceres::LossFunction* loss, Solution* sol) {
  sol->sqrt_w.assign(os.obs.size(), 1.0);
  std::vector<double> w_prev(os.obs.size(), 1.0);
  for (int round = 0; round < kIrlsRounds; ++round) {
    sol->problem = new_problem();
    if (!m->add_reweighted(sol->problem.get(), os, &sol->sqrt_w)) return false;
    ceres::Solver::Summary round_sum;
    ceres::Solve(solver_options(opt), sol->problem.get(), &round_sum);
    accumulate(round_sum, round == 0, &sol->summary);
    if (!loss) break;
    double change = 0;  // new weights from the unweighted residuals
    for (size_t i = 0; i < os.obs.size(); ++i) {
      double ri[3];
      m->residual(os, i, ri);
      double rho[3];
      loss->Evaluate(ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2], rho);
      change = std::max(change, std::abs(rho[1] - w_prev[i]));
      w_prev[i] = rho[1];
      sol->sqrt_w[i] = std::sqrt(std::max(rho[1], 0.0));
    }
    sol->weights_change = change;
    if (change < kWeightsSettled) break;
  }
  return true;
}

// The residual statistics of the solution: RMS, RSS, BIC (Gaussian residuals, for --model
// auto), and whether the model describes the data. sol->rss is already known after a fused solve.
void summarize(const ObsSet& os, size_t nparam, Solution* sol, FitReport* rep) {
  if (sol->problem) {
    const ceres::Solver::Summary& sum = sol->summary;
    rep->iterations = static_cast<int>(sum.iterations.size()) - 1;
    rep->termination = ceres::TerminationTypeToString(sum.termination_type);
    rep->residual_evaluations = sum.num_residual_evaluations;
    rep->jacobian_evaluations = sum.num_jacobian_evaluations;
    rep->convergence.clear();
    for (const auto& it : sum.iterations) rep->convergence.push_back(it.cost);
    if (sum.termination_type == ceres::FAILURE)
      throw Error("fit: the solver failed: " + sum.message);
    std::vector<double> r;
    sol->problem->Evaluate(ceres::Problem::EvaluateOptions(), nullptr, &r, nullptr, nullptr);
    double rss = 0;
    for (double x : r) rss += x * x;
    sol->rss = rss;
  }
  sol->values = static_cast<double>(os.obs.size()) * (os.grey ? 1 : 3);
  const double m = sol->values;
  const double rss = sol->rss;
  rep->rms = std::sqrt(rss / (os.grey ? 3 * m : m));
  rep->rss = rss / (os.grey ? 3 : 1);
  rep->parameters = nparam;
  rep->bic =
      m * std::log(std::max(rep->rss, 1e-300) / m) + static_cast<double>(nparam) * std::log(m);
  rep->pixel_noise = os.pixel_noise;
  if (auto w = misfit_warning(os, *rep); !w.empty())
    rep->warnings.push_back({w, WarningAbout::kGlobalMisfit}), sol->misfit = true;
}

// Stage 1 by Ceres: plain least squares on the start subset; its residuals.
std::vector<double> settle_with_ceres(ModelFit* m, const ObsSet& os,
                                      const std::vector<size_t>& subset, const FitOptions& opt) {
  auto pb = new_problem();
  m->add_residuals(pb.get(), os, subset, nullptr);
  ceres::Solver::Summary s1;
  ceres::Solve(solver_options(opt), pb.get(), &s1);
  std::vector<double> r;
  pb->Evaluate(ceres::Problem::EvaluateOptions(), nullptr, &r, nullptr, nullptr);
  return r;
}

// Stage 2 by the model's fused solver; false (nothing changed) where it has none. On a large set
// it runs on every k-th pixel first (fit.h kStagedPixels), then on every pixel from there.
bool solve_fused(ModelFit* m, const ObsSet& os, const FitOptions& opt, FitReport* rep,
                 Solution* sol) {
  const size_t n = os.obs.size();
  const int stride =
      opt.staged_pixels > 0
          ? static_cast<int>(std::min<double>(kStagedStride, std::floor(n / opt.staged_pixels)))
          : 0;
  if (stride >= kMinStagedStride) {
    // Every k-th pixel in the set's order (views after one another, rows within a view): spread
    // over views and sample alike, and read in order.
    std::vector<size_t> every_kth;
    every_kth.reserve(n / stride + 1);
    for (size_t i = 0; i < n; i += static_cast<size_t>(stride)) every_kth.push_back(i);
    FusedSolve first;
    if (!m->solve_fused(os, &every_kth, opt.loss, rep->loss_scale, opt, &first)) return false;
    rep->staged_stride = stride;
    rep->staged_iterations = first.iterations;
  }
  FusedSolve f;
  f.record_costs = true;
  if (!m->solve_fused(os, nullptr, opt.loss, rep->loss_scale, opt, &f)) return false;
  sol->information = f.info;
  sol->information_order = f.order;
  sol->rss = f.rss;
  rep->iterations = f.iterations;
  rep->convergence = f.costs;
  rep->termination = f.converged ? "CONVERGENCE" : "NO_CONVERGENCE";
  rep->stopped_on_crawl = f.crawled;
  rep->residual_evaluations = rep->jacobian_evaluations = static_cast<size_t>(f.passes);
  rep->solver = "fused LM";
  rep->pass = m->model() == Model::kLine && line_lanes_on(opt.line_lanes.simd) &&
                      opt.loss != FitLoss::kCauchy
                  ? "4 pixels at a time where a pixel has one light (AVX2, FMA)"
                  : "one pixel at a time";
  return true;
}

}  // namespace

void set_core_bounds(ceres::Problem* pb, Core* c) {
  for (int k = 0; k < 3; ++k) {
    set_param_bounds(pb, c->kd, k, "kd");
    set_param_bounds(pb, c->ks, k, "ks");
  }
  set_param_bounds(pb, &c->logn, 0, "n");
  pb->SetManifold(&c->psi, new HalfTurnManifold);
}

void set_param_bounds(ceres::Problem* pb, double* block, int index, const char* key) {
  const ParamSpec& p = line_param(key);
  pb->SetParameterLowerBound(block, index, p.fit_log ? std::log(p.lo) : p.lo);
  pb->SetParameterUpperBound(block, index, p.fit_log ? std::log(p.hi) : p.hi);
}

std::string second_look(ModelFit* m, const std::vector<double>& start_own, size_t pixels,
                        size_t subset, bool grey,
                        const std::function<std::vector<double>()>& settle, std::vector<double>* r,
                        FitReport* rep) {
  auto sum_sq = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return s;
  };
  const Core first = m->core;
  const std::vector<double> first_own = m->own();
  const double c1 = sum_sq(*r);
  m->core = *m->other;
  m->set_own(start_own);
  std::vector<double> r2 = settle();
  const double c2 = sum_sq(r2);
  const Core second = m->core;
  const bool take_second = c2 < c1;
  if (take_second) {
    r->swap(r2);
  } else {
    m->core = first;
    m->set_own(first_own);
  }
  const Core& other = take_second ? first : second;
  constexpr double kSameDeg = 1.0;  // the two settled in one valley
  const double apart = std::abs(std::remainder(second.psi - first.psi, M_PI));
  if (apart < deg_to_rad(kSameDeg)) return "";
  if (take_second) {  // the grid's best node was in the worse valley
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "; settled from the grid's other valley too: psi=%.1f deg, lower",
                  rad_to_deg(wrap_half_turn(second.psi)));
    rep->start += buf;
  }
  // A grey set's three channels repeat one value: one residual a pixel, not three.
  const double per_value = grey ? 1.0 / 3 : 1.0;
  const double dof = std::max(1.0, static_cast<double>(r->size()) * per_value - 8.0);
  constexpr double kSigma2Floor = 1e-12;  // noise-free data: (1e-6)^2, the loss scale's floor
  const double s2 = std::max(std::min(c1, c2) * per_value / dof, kSigma2Floor);
  const double whole =
      std::abs(c1 - c2) * per_value * static_cast<double>(pixels) / static_cast<double>(subset);
  if (!(whole <= kAsWellSigma2 * s2)) return "";
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "two fiber directions fit the data as well: psi = %.2f deg (taken) and psi = %.2f "
                "deg (n %.3g; sums of squares %.3g sigma^2 apart, scaled to every pixel): the data "
                "cannot tell them apart (as where every view and light lies in one plane through "
                "the normal); check the other against the sample, or add views out of that plane",
                rad_to_deg(wrap_half_turn(m->core.psi)), rad_to_deg(wrap_half_turn(other.psi)),
                std::exp(other.logn), whole / s2);
  return buf;
}

Solution solve(ModelFit* m, const ObsSet& os, const FitOptions& opt, FitReport* rep) {
  Solution sol;
  const auto t_start = Clock::now();
  rep->start = m->start(os, opt.progress);
  const std::vector<double> start_own = m->own();
  // Stage 1: plain least squares on the start subset to settle near the optimum and measure noise.
  {
    const std::vector<size_t> subset = start_subset(os.obs.size(), kMaxStartObs);
    auto settle = [&] {
      FusedSolve f;
      std::vector<double> r;
      if (m->solve_fused(os, &subset, FitLoss::kNone, 0, opt, &f)) {
        r.resize(3 * subset.size());
        for (size_t j = 0; j < subset.size(); ++j) m->residual(os, subset[j], &r[3 * j]);
      } else {
        r = settle_with_ceres(m, os, subset, opt);
      }
      return r;
    };
    std::vector<double> r = settle();
    if (m->other)
      sol.other_minimum =
          second_look(m, start_own, os.obs.size(), subset.size(), os.grey, settle, &r, rep);
    rep->noise_sigma = 1.4826 * median_abs(r);  // robust sigma (MAD) of the residuals
  }
  rep->seconds_start = seconds_since(t_start);

  // Stage 2: all observations with the robust loss, scaled to 3 robust sigmas (outliers beyond
  // it, e.g. specks or unmodelled glints, count linearly instead of quadratically). A floor keeps
  // the scale meaningful on noise-free data.
  const auto t_solve = Clock::now();
  constexpr double kLossScaleFloor = 1e-6;
  rep->loss_scale = std::max(3.0 * rep->noise_sigma, kLossScaleFloor);
  std::unique_ptr<ceres::LossFunction> loss(make_loss(opt.loss, rep->loss_scale));
  rep->loss =
      loss ? std::string(fit_loss_name(opt.loss)) + "(" + std::to_string(rep->loss_scale) + ")"
           : "none";
  rep->solver = "ceres";
  if (solve_fused(m, os, opt, rep, &sol)) {
    // found by the model's own solver
  } else if (!solve_reweighted(m, os, opt, loss.get(), &sol)) {
    sol = Solution{};
    std::vector<size_t> all(os.obs.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = i;
    sol.problem = new_problem();
    m->add_residuals(sol.problem.get(), os, all, loss.release());  // the problem owns it
    ceres::Solver::Options so = solver_options(opt);
    CrawlStop crawl(static_cast<double>(os.obs.size()) * (os.grey ? 1 : 3), m->parameters());
    so.callbacks.push_back(&crawl);
    ceres::Solve(so, sol.problem.get(), &sol.summary);
    if (crawl.crawled) sol.summary.termination_type = ceres::CONVERGENCE;
    rep->stopped_on_crawl = crawl.crawled;
  }
  if (opt.progress) opt.progress->status("");  // the iteration line
  summarize(os, m->parameters(), &sol, rep);
  if (sol.weights_change >= kWeightsSettled) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2g", sol.weights_change);
    rep->termination = "NO_CONVERGENCE";
    rep->warnings.push_back("the robust loss's weights (Ceres, reweighted) still moved by " +
                            std::string(buf) + " in the last of " + std::to_string(kIrlsRounds) +
                            " rounds: the numbers may not be the minimum");
  } else if (rep->termination == "NO_CONVERGENCE") {  // either solver
    rep->warnings.push_back({"the solver stopped after --max-iterations " +
                                 std::to_string(opt.max_iterations) +
                                 " steps before converging: the numbers may not be the minimum",
                             WarningAbout::kSolverStopped});
  }
  rep->seconds_solve = seconds_since(t_solve);
  return sol;
}

}  // namespace aniso::fitting
