// One texel of --maps (fit/maps/texel_solve.h), the line model's: its start (a grid over psi with
// k_d, k_s in closed form), its solve by the LM or by Ceres, and its sigmas (the fiber model's
// texels: fit/maps/texel_fiber.cpp; the checks after a solve both share: fit/maps/texel_shared.h).
#include <ceres/normal_prior.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>

#include "core/angles.h"
#include "fit/maps/texel_shared.h"
#include "fit/maps/texel_sigmas.h"
#include "fit/maps/texel_solve.h"
#include "fit/solvers/line_pixel.h"
#include "fit/solvers/line_pixel_lanes.h"
#include "fit/solvers/start.h"
#include "fit/solvers/texel_lanes.h"
#include "models/params.h"

namespace aniso::fitting {

void texel_nodes(const ObsSet& os, const std::vector<size_t>& idx, const TexelLanes* lanes,
                 const double* psi, int log2n, NodeFit* out) {
  if (lanes) {
    KdKsSums sums[8];
    texel_nodes_f32(*lanes, psi, log2n, sums);
    solve_kd_ks8(sums, out);
  } else {
    line_nodes_cost(os, idx, psi, 8, log2n, out);
  }
}

namespace {

// Grid over psi with k_d, k_s in closed form at the power of two nearest the global n (x^n by
// squaring: this grid was most of the texel phase with a pow per pixel): the texel's start. With
// `lanes`, eight nodes at a time in float (fit/solvers/texel_lanes.h). Every 22.5 degrees, then 5.6
// and 11.25 degrees either side of the best two: 16 nodes, which end in another basin than the
// truth's less often than a 15-degree grid with four more (docs/solver-rules.md "The start's
// grid"). With `other`, the best node of another valley too.
void texel_start(const ObsSet& os, const std::vector<size_t>& idx, const TexelLanes* lanes, Core* c,
                 OtherValley* other) {
  const int log2n = std::clamp(static_cast<int>(std::lround(c->logn / std::log(2.0))), 1, 12);
  int m[16];  // each node's place on the grid of texel_grid_angle
  double psi[16];
  NodeFit fit[16];
  auto nodes_at = [&](double* at, int l2, NodeFit* out) {
    texel_nodes(os, idx, lanes, at, l2, out);
  };
  auto nodes = [&](double* at, NodeFit* out) { nodes_at(at, log2n, out); };
  // On the grid of texel_grid_angle: m = 4k, then m of the best two +-1, +-2 (modulo a half turn).
  for (int k = 0; k < 8; ++k) m[k] = 4 * k, psi[k] = texel_grid_angle(m[k]);
  nodes(psi, fit);
  int b1 = 0, b2 = -1;
  for (int k = 1; k < 8; ++k)
    if (fit[k].cost < fit[b1].cost) b1 = k;
  for (int k = 0; k < 8; ++k)
    if (k != b1 && (b2 < 0 || fit[k].cost < fit[b2].cost)) b2 = k;
  const int off[4] = {-2, -1, 1, 2};
  for (int k = 0; k < 4; ++k) {
    m[8 + k] = (4 * b1 + off[k] + 32) % 32, m[12 + k] = (4 * b2 + off[k] + 32) % 32;
    psi[8 + k] = texel_grid_angle(m[8 + k]), psi[12 + k] = texel_grid_angle(m[12 + k]);
  }
  nodes(psi + 8, fit + 8);
  int best = b1;  // the first of equal costs, round one's before round two's
  for (int k = 8; k < 16; ++k)
    if (fit[k].cost < fit[best].cost) best = k;
  c->psi = psi[best];
  set_start_kd_ks(fit[best].kd, fit[best].ks, c);
  const Core grid = *c;  // at the grid's n: the other valley's nodes were taken there
  // A best node whose k_s the closed form put on its bound: a lobe at this n lighting next to no
  // pixel, where the LM stays at its start (n's column all but zero, each step in n huge and
  // rejected until the step is "small" in sigmas). Nodes within 22.5 degrees of it again at
  // broader lobes (a quarter of n, and 2), the lowest kept (not the whole half turn: a broad lobe
  // fits a wrong valley as well; docs/solver-rules.md "Broader lobes"): test
  // Trust.AStartWhoseLobeLightsNoPixelIsLookedForAtBroaderLobes.
  static const double ks_hi = line_param("ks").hi;
  if (std::max({fit[best].ks[0], fit[best].ks[1], fit[best].ks[2]}) >= ks_hi) {
    double near[8];
    for (int k = 0; k < 8; ++k) near[k] = texel_grid_angle((m[best] + k - 4 + 32) % 32);
    double best_cost = fit[best].cost;
    const int levels[2] = {std::max(1, log2n - 2), 1};
    for (int i = 0; i < 2; ++i) {
      const int broader = levels[i];
      if (broader >= log2n || (i == 1 && levels[0] == 1)) continue;
      NodeFit at[8];
      nodes_at(near, broader, at);
      int b = 0;
      for (int k = 1; k < 8; ++k)
        if (at[k].cost < at[b].cost) b = k;
      if (!(at[b].cost < best_cost)) continue;
      best_cost = at[b].cost;
      c->psi = near[b];
      c->logn = broader * std::log(2.0);
      set_start_kd_ks(at[b].kd, at[b].ks, c);
    }
  }
  if (!other) return;
  other->best_cost = fit[best].cost;
  // Whether two nodes of the grid lie kOtherValleyDeg or more apart modulo a half turn: the same
  // test on the same doubles, once for every pair of the grid's 32 places (not a std::remainder per
  // node).
  static const auto far_apart = [] {
    std::array<std::array<bool, 32>, 32> t{};
    for (int a = 0; a < 32; ++a)
      for (int b = 0; b < 32; ++b)
        t[a][b] = std::abs(std::remainder(texel_grid_angle(a) - texel_grid_angle(b), M_PI)) >=
                  deg_to_rad(kOtherValleyDeg);
    return t;
  }();
  for (int k = 0; k < 16; ++k) {
    if (far_apart[m[k]][m[best]] && fit[k].cost < other->cost) {
      other->cost = fit[k].cost;
      other->c = grid;
      other->c.psi = psi[k];
      set_start_kd_ks(fit[k].kd, fit[k].ks, &other->c);
    }
  }
}

// The texel's observations as float lanes (false where they cannot be: then none) and, without a
// pull, its start from the grid over psi: the LM and Ceres start from the same node.
bool texel_begin(const ObsSet& os, const std::vector<size_t>& idx, const TexelPrior* prior,
                 bool wide, TexelLanes* lanes, Core* c, OtherValley* other = nullptr) {
  const bool f32 = texel_lanes(os, idx, lanes, wide);
  if (!prior) texel_start(os, idx, f32 ? lanes : nullptr, c, other);
  return f32;
}

// --smooth's pull on psi toward its target, modulo a half turn (psi lives on Ceres' half-turn
// manifold, so it may wrap past the target).
class PsiPrior : public ceres::SizedCostFunction<1, 1> {
 public:
  PsiPrior(double sqrt_w, double target) : sqrt_w_(sqrt_w), target_(target) {}
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    r[0] = sqrt_w_ * std::remainder(p[0][0] - target_, M_PI);
    if (jac && jac[0]) jac[0][0] = sqrt_w_;
    return true;
  }

 private:
  double sqrt_w_, target_;
};

Vec8 prior_diff(const TexelPrior& p, const Vec8& x) {
  Vec8 d = x - p.b;
  d(7) = std::remainder(d(7), M_PI);
  return d;
}

}  // namespace

// NormalPriors on k_d, k_s, log n, PsiPrior on psi.
void add_prior(const TexelPrior& prior, ceres::Problem* pb, Core* c) {
  const std::pair<double*, int> blocks[3] = {{c->kd, 0}, {c->ks, 3}, {&c->logn, 6}};
  for (const auto& [block, at] : blocks) {
    const int size = at < 6 ? 3 : 1;
    const Eigen::VectorXd w = prior.w.segment(at, size).cwiseSqrt();
    pb->AddResidualBlock(
        new ceres::NormalPrior(w.asDiagonal().toDenseMatrix(), prior.b.segment(at, size)), nullptr,
        block);
  }
  pb->AddResidualBlock(new PsiPrior(std::sqrt(prior.w(7)), prior.b(7)), nullptr, &c->psi);
}

namespace {

double texel_pass(const ObsSet& os, const std::vector<size_t>& idx, const TexelLanes* lanes,
                  bool in_float, const Vec8& x, Mat8* info, Vec8* grad);
Vec8 texel_inverse_diagonal(const Mat8& H);

// The ridge rule of the LM (fit/solvers/fused_lm.h kRidgeIterations) for a line texel's Ceres
// solve: past kRidgeIterations, every kRidgeWindow successful steps, done where k_d and psi moved
// less than kRidgeSettledSigma of their sigma (J^T J of the texel's data at the point, in double
// from its records: Problem::Evaluate may not be called during a solve). Without it Ceres crawls
// along the ridge to its iteration limit where the LM stops (docs/solver-rules.md "The ridge
// rule").
class TexelRidgeCallback : public ceres::IterationCallback {
 public:
  TexelRidgeCallback(const ObsSet& os, const std::vector<size_t>& idx, const Core* c)
      : os_(os), idx_(idx), c_(c), window_start_(pack_core(*c)) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (s.iteration == 0 || !s.step_is_successful || ++accepted_ % kRidgeWindow != 0)
      return ceres::SOLVER_CONTINUE;
    const Vec8 x = pack_core(*c_);
    if (s.iteration >= kRidgeIterations) {
      Mat8 info;
      Vec8 grad, moved = x - window_start_;
      const double rss = texel_pass(os_, idx_, nullptr, false, x, &info, &grad);
      moved.segment<4>(3).setZero();  // k_s, log n: the ridge
      moved(7) = std::remainder(moved(7), M_PI);
      if (step_in_sigmas_d<8>(texel_inverse_diagonal(info), moved, rss, 3.0 * idx_.size()) <
          kRidgeSettledSigma)
        return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    window_start_ = x;
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const ObsSet& os_;
  const std::vector<size_t>& idx_;
  const Core* c_;
  Vec8 window_start_;
  int accepted_ = 0;
};

}  // namespace

void solve_and_sigmas(ceres::Problem* pb, const std::vector<ceres::ResidualBlockId>& data,
                      const std::vector<double*>& blocks, int max_iterations, TexelResult* t,
                      NoLobe hold, ceres::IterationCallback* ridge, double trust_radius) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  if (trust_radius > 0) so.initial_trust_region_radius = trust_radius;
  so.max_num_iterations = max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  if (ridge) so.callbacks.push_back(ridge), so.update_state_every_iteration = true;
  // Converged as far as double precision takes it, as the LM path: the reference to compare with.
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  ceres::Solver::Summary sum;
  ceres::Solve(so, pb, &sum);
  t->rss = 2 * sum.final_cost;  // the sum of squares where the sigmas below are not to be had
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.residual_blocks = data;  // sigma from the texel's own data
  double cost = 0;
  ceres::CRSMatrix J;
  int P = 0;
  for (double* b : blocks) P += pb->ParameterBlockSize(b);
  if (!pb->Evaluate(eo, &cost, nullptr, nullptr, &J) || J.num_cols != P) return;
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(P, P);
  for (int r = 0; r < J.num_rows; ++r)
    for (int a = J.rows[r]; a < J.rows[r + 1]; ++a)
      for (int b = J.rows[r]; b < J.rows[r + 1]; ++b)
        info(J.cols[a], J.cols[b]) += J.values[a] * J.values[b];
  texel_sigmas(info, 2 * cost, J.num_rows, t, hold);
  mark_converged(sum.termination_type == ceres::CONVERGENCE ||
                     (ridge && sum.termination_type == ceres::USER_SUCCESS),
                 t);
}

namespace {

// One texel with Ceres from `start` as it is: solve, then J^T J of its own problem.
TexelResult texel_ceres_from(const ObsSet& os, const std::vector<size_t>& idx, const Core& start,
                             const TexelPrior* prior, int max_iterations, bool pin_psi = false) {
  TexelResult t;
  t.c = start;
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem pb(po);
  double dummy[2] = {0, 0};
  Core& c = t.c;
  std::vector<ceres::ResidualBlockId> data;
  for (size_t i : idx)
    data.push_back(pb.AddResidualBlock(line_pixel_cost(&os.obs[i], os.lights.data()), nullptr, c.kd,
                                       c.ks, &c.logn, &c.psi, &dummy[0], &dummy[1]));
  if (prior) add_prior(*prior, &pb, &c);
  pb.SetParameterBlockConstant(&dummy[0]);
  pb.SetParameterBlockConstant(&dummy[1]);
  set_core_bounds(&pb, &c);
  if (pin_psi) pb.SetParameterBlockConstant(&c.psi);
  TexelRidgeCallback ridge(os, idx, &c);
  // Not with a pull: the LM measures the steps with the pull in J^T J, which this rule does not
  // see (with it the two paths' --smooth maps differed by up to 0.14 sigma).
  solve_and_sigmas(&pb, data, {c.kd, c.ks, &c.logn, &c.psi}, max_iterations, &t, NoLobe::kHoldN,
                   prior ? nullptr : &ridge);
  return t;
}

}  // namespace

// One texel with Ceres (the fitter of record): the LM path's start and second look.
TexelResult solve_texel_ceres(const ObsSet& os, const std::vector<size_t>& idx, const Core& from,
                              const TexelPrior* prior, int max_iterations, bool wide) {
  Core start = from;
  TexelLanes lanes;  // the same start as the LM path
  OtherValley other;
  const bool f32 = texel_begin(os, idx, prior, wide, &lanes, &start, &other);
  TexelResult t = texel_ceres_from(os, idx, start, prior, max_iterations);
  if (!prior) {
    auto from = [&](const Core& c) {
      return texel_ceres_from(os, idx, c, nullptr, max_iterations);
    };
    texel_second_look(
        other, 3 * idx.size(), from, [&](const TexelResult& r) { return from(r.c); }, &t);
    texel_psi_profile(
        3 * idx.size(), line_profile_nodes(os, idx, f32 ? &lanes : nullptr),
        [&](const Core& c) { return texel_ceres_from(os, idx, c, nullptr, max_iterations, true); },
        &t);
  }
  return t;
}

namespace {

// Sum of squares, and (info, grad) = (J^T J, J^T r) when asked, in one pass over the texel: from
// `lanes` (in float with `in_float`, else in double), or from the records in double.
double texel_pass(const ObsSet& os, const std::vector<size_t>& idx, const TexelLanes* lanes,
                  bool in_float, const Vec8& x, Mat8* info, Vec8* grad) {
  const double kd[3] = {x(0), x(1), x(2)}, ks[3] = {x(3), x(4), x(5)};
  const LinePixelParams p{kd, ks, std::exp(x(6)), std::cos(x(7)), std::sin(x(7))};
  ChannelSums<8> s;
  if (lanes && in_float)
    texel_pass_f32(*lanes, p, info != nullptr, &s);
  else if (lanes)
    line_pass_lanes(*lanes, p, info != nullptr, &s);
  else
    line_chunk(os, idx.data(), 0, idx.size(), p, RobustLoss{FitLoss::kNone, 0}, info != nullptr,
               &s);
  if (info) {
    FusedSums<8> f;
    s.scatter(&f);
    *info = f.H.selfadjointView<Eigen::Upper>();
    *grad = f.g;
  }
  return s.cost;
}

// H^-1's diagonal and H^-1 b, by TexelBlocks where it applies, else Eigen's pivoting LDLT.
Vec8 texel_inverse_diagonal(const Mat8& H) {
  TexelBlocks f;
  return f.factor(H) ? f.inverse_diagonal() : inverse_diagonal<8>(H);
}
Vec8 texel_solve(const Mat8& A, const Vec8& b) {
  TexelBlocks f;
  return f.factor(A) ? f.solve(b) : Vec8(A.ldlt().solve(b));
}

// One texel with a hand-written Levenberg-Marquardt (the fast path of --maps): the same
// function (fit/solvers/line_pixel.h), the same bounds (projected) and the same start as the Ceres
// path; the tests check that both reach the same minimum. The steps run in float
// (fit/solvers/texel_lanes.h) until they are under kFloatStepInSigma, where float's rounding of the
// cost (~1e-7 of it) starts to hide a step's gain; then in double from there to the end (J^T J, J^T
// r and the sigmas too).
constexpr double kFloatStepInSigma = 0.05;
// A texel's last step is taken unconfirmed only under this: the global solve's 0.1 leaves texels
// further from Ceres' minimum, confirming every step costs a pass (docs/solver-rules.md "The last
// step").
constexpr double kTexelLastStepInSigma = 0.02;
constexpr int kZigZagIterations = 20;
// A ridge (fit/solvers/fused_lm.h kRidgeIterations): k_s and n trading off, k_d and psi put.

// The texel's objective at a point: the data's sum of squares with J^T J, J^T r, and the same
// with the prior added. A trial point is evaluated with its derivatives at once: most steps are
// taken, and a second pass at the same point would cost more than the derivatives of the few
// that are not.
struct TexelEval {
  Mat8 info, h;
  Vec8 grad, g, hinv;  // hinv: the diagonal of h^-1, once per point (rejected steps reuse it)
  double rss = 0, total = 0;
  bool have_hinv = false;
};

struct TexelObjective {
  const ObsSet& os;
  const std::vector<size_t>& idx;
  const TexelLanes* lanes;  // null: from the records in double
  const TexelPrior* prior;
  bool in_float;
  Vec8 lo, hi;
  int max_iterations;
  bool pin_psi = false;   // psi held where it starts (the profile of texel_psi_profile)
  double lambda0 = 1e-3;  // the damping of the first step

  // The step of the system a x = -g; with pin_psi, psi's row and column out of it (no step in psi).
  Vec8 step_of(const Mat8& damped, const Vec8& g) const {
    if (!pin_psi) return texel_solve(damped, -g);
    Mat8 a = damped;
    a.row(7).setZero();
    a.col(7).setZero();
    a(7, 7) = 1;
    Vec8 step = texel_solve(a, -g);
    step(7) = 0;
    return step;
  }

  void evaluate(const Vec8& at, TexelEval* e) const {
    e->have_hinv = false;
    e->rss = texel_pass(os, idx, lanes, in_float, at, &e->info, &e->grad);
    e->h = e->info, e->g = e->grad, e->total = e->rss;
    if (!prior) return;
    const Vec8 d = prior_diff(*prior, at);
    e->h.diagonal() += prior->w;
    e->g += prior->w.cwiseProduct(d);
    e->total += prior->w.dot(d.cwiseProduct(d));
  }
  double in_sigmas(TexelEval* e, const Vec8& step) const {
    if (!e->have_hinv) e->hinv = texel_inverse_diagonal(e->h), e->have_hinv = true;
    return step_in_sigmas_d<8>(e->hinv, step, e->total, 3.0 * idx.size());
  }
  // k_d (0-2) and psi (7) moved by less than kRidgeSettledSigma of their sigma.
  bool ridge_settled(TexelEval* e, Vec8 moved) const {
    moved.segment<4>(3).setZero();  // k_s, log n: the ridge
    moved(7) = std::remainder(moved(7), M_PI);
    return in_sigmas(e, moved) < kRidgeSettledSigma;
  }
  Vec8 bounded(const Vec8& xn) const {
    Vec8 b = xn.cwiseMax(lo).cwiseMin(hi);
    b(7) = wrap_half_turn(b(7));
    return b;
  }

  // Levenberg-Marquardt from *x until a step is under `stop` sigma; *out ends at *x, *taken is
  // the size of the last step taken, in sigmas. False where it stopped at its iteration limit.
  bool run(double stop, Vec8* x, TexelEval* out, double* taken) const {
    // The point and the trial trade places on a step taken (a TexelEval is ~1.3 KB: copying it
    // and the damped system was a quarter of this loop's own time); *out gets the point at the end.
    TexelEval other;
    TexelEval* cur = out;
    const bool ok = steps(stop, x, &cur, &other, taken);
    if (cur != out) *out = *cur;
    return ok;
  }
  // run's steps: *cur_at is where the point's evaluation is, `trial` the other one.
  bool steps(double stop, Vec8* x, TexelEval** cur_at, TexelEval* trial, double* taken) const {
    TexelEval*& cur = *cur_at;
    evaluate(*x, cur);
    double lambda = lambda0;
    Vec8 window_start = *x;
    int accepted = 0;
    for (int it = 0; it < max_iterations; ++it) {
      // Damped by lambda times J^T J's diagonal, floored at kMinDiagonal (fit/solvers/fused_lm.h:
      // Ceres' min_diagonal): a parameter the data hardly see (n where a lobe lights next to no
      // pixel) is damped too: with a smaller floor such a column's steps stay huge and are clamped
      // at the bounds, lambda grows until every step is a thousandth of a sigma, and the LM calls
      // its start converged (docs/solver-rules.md "The damping floor").
      Mat8 a = cur->h;
      a.diagonal() += lambda * cur->h.diagonal().cwiseMax(kMinDiagonal);
      const Vec8 step = step_of(a, cur->g);
      const double size = in_sigmas(cur, step);
      if (size < stop) return true;
      const Vec8 xn = bounded(*x + step);
      evaluate(xn, trial);
      if (trial->total < cur->total) {
        // Done where the step lowered the cost by less than a step of kStepInSigma would, once
        // past kZigZagIterations: a curved valley's Gauss-Newton steps can zig-zag across it for
        // ever, each a little lower (they reached the 100-iteration limit); a texel that converges
        // does so in a few.
        const double s2 = cur->total / std::max(1.0, 3.0 * idx.size() - 8);
        const double gain = cur->total - trial->total;
        const bool done = gain <= 1e-12 * cur->total ||
                          (it >= kZigZagIterations && gain <= kStepInSigma * kStepInSigma * s2);
        *taken = size;
        *x = xn;
        std::swap(cur, trial);
        lambda = std::max(lambda / 3, 1e-12);
        if (done) return true;
        if (++accepted % kRidgeWindow == 0) {
          if (it >= kRidgeIterations && ridge_settled(cur, *x - window_start)) return true;
          window_start = *x;
        }
      } else {
        if (in_float && size < 4 * stop) return true;  // within float's rounding of the cost
        lambda *= 4;
        if (lambda > 1e12) return true;  // no step lowers the cost: a minimum
      }
    }
    return false;
  }

  // Past where float's cost tells steps apart its gradient still does (the step it gives is off
  // by ~1e-5 sigma): Gauss-Newton steps without the cost test while they stay inside the bounds
  // and shrink, to the usual 1e-3 sigma. The last is taken without a pass to confirm it by the
  // global solve's rule (fit/solvers/fused_lm.h): under kTexelLastStepInSigma and shrinking fast
  // enough after the step before (`taken`) that what is left after it is under kStepInSigma; J^T J
  // and the sum of squares stay those of the point before. False where something else (a bound in
  // the way, a step that grows or is still large) needs the cost test.
  bool polish(Vec8* x, TexelEval* cur, double taken) const {
    double last = kFloatStepInSigma;
    for (int it = 0; it < 4; ++it) {
      const Vec8 step = step_of(cur->h, cur->g);
      const double size = in_sigmas(cur, step);
      if (size < kStepInSigma) return true;
      const Vec8 xn = *x + step;
      if (!(size < last) || bounded(xn) != xn) return false;
      *x = xn;
      if (size < kTexelLastStepInSigma && size * size < kStepInSigma * taken) return true;
      last = taken = size;
      evaluate(*x, cur);
    }
    return false;
  }
};

}  // namespace

namespace {

// The LM of solve_texel_lm from `start` as it is.
TexelResult texel_lm_from(const ObsSet& os, const std::vector<size_t>& idx, const Core& start,
                          const TexelLanes* lanes, const TexelPrior* prior, int max_iterations,
                          bool pin_psi = false, double lambda0 = 1e-3) {
  TexelResult t;
  t.c = start;
  TexelObjective obj{os,     idx,    lanes,          prior,   lanes != nullptr,
                     Vec8(), Vec8(), max_iterations, pin_psi, lambda0};
  core_bounds(&obj.lo, &obj.hi);
  Vec8 x = pack_core(t.c);
  TexelEval cur;
  bool converged = false;
  double taken = kFloatStepInSigma;  // no step taken: as if the last had been at the switch
  if (lanes) {
    obj.run(kFloatStepInSigma, &x, &cur, &taken);
    converged = obj.polish(&x, &cur, taken);
  }
  // In double to the end: the same stopping rule as the global fused solve (a step under 1e-3
  // sigma is not taken); from the float solution one or two passes.
  obj.in_float = false;
  const bool from_float = converged;  // cur's sums then float's
  if (!converged) converged = obj.run(kStepInSigma, &x, &cur, &taken);
  unpack_core(x, &t.c);
  texel_sigmas(cur.info, cur.rss, 3.0 * idx.size(), &t, NoLobe::kHoldN);
  // J^T J in float fails the rank test where a column is a few orders below the others (k_s at
  // 1e-4, no lobe: n's column is k_s times the lobe's): float's rounding of its sums is then not
  // small against them. In double the test is Ceres' (docs/solver-rules.md "The rank test in
  // double").
  if (from_float && t.sigma[7] == 0) {
    obj.evaluate(x, &cur);
    texel_sigmas(cur.info, cur.rss, 3.0 * idx.size(), &t, NoLobe::kHoldN);
  }
  mark_converged(converged, &t);
  return t;
}

}  // namespace

TexelResult solve_texel_lm(const ObsSet& os, const std::vector<size_t>& idx, const Core& from,
                           const TexelPrior* prior, int max_iterations, bool wide) {
  Core start = from;
  thread_local TexelLanes lanes;  // each thread's buffer, reused texel after texel
  OtherValley other;
  const bool f32 = texel_begin(os, idx, prior, wide, &lanes, &start, &other);
  const TexelLanes* in_lanes = f32 ? &lanes : nullptr;
  TexelResult t = texel_lm_from(os, idx, start, in_lanes, prior, max_iterations);
  if (!prior && !t.determined && lobe_at_upper_bound(t.c)) {
    const TexelResult cautious =
        texel_lm_from(os, idx, start, in_lanes, nullptr, max_iterations, false, kCautiousLambda);
    if (cautious.rss < t.rss) t = cautious;
  }
  if (!prior) {
    auto from = [&](const Core& c) {
      return texel_lm_from(os, idx, c, in_lanes, nullptr, max_iterations);
    };
    texel_second_look(
        other, 3 * idx.size(), from, [&](const TexelResult& r) { return from(r.c); }, &t);
    texel_psi_profile(
        3 * idx.size(), line_profile_nodes(os, idx, in_lanes),
        [&](const Core& c) {
          return texel_lm_from(os, idx, c, in_lanes, nullptr, max_iterations, true);
        },
        &t);
  }
  return t;
}

}  // namespace aniso::fitting
