// fit/ internal: the fused Levenberg-Marquardt shared by the models that have one (the plain line
// model, fit/solvers/line_solve.cpp; the fiber model, fit/solvers/fiber_solve.cpp; the isotropic
// part alone, fit/global/isotropic_alternative.cpp, P = 7 with log n_iso its one shared column and
// no psi). Every iteration is one pass over the observations that sums the robust cost, J^T W J and
// J^T W r together; the pass runs on TBB in fixed chunks summed in order, so the answer does not
// depend on the scheduling. The parameter vector is the core (k_d 3, k_s 3, log n, psi) and P - 8
// of the model's own numbers; a channel's Jacobian row is nonzero at k_d[k], k_s[k] and the P - 6
// shared columns (log n, psi,
// ...). The robust loss enters by its weights rho'(|r|^2) at the current point (iteratively
// reweighted least squares inside LM): its fixed point is the minimum Ceres finds with the same
// loss.
#pragma once
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/angles.h"
#include "fit/solvers/crawl.h"
#include "fit/solvers/model_fit.h"
#include "fit/types/fit_types.h"

namespace aniso::fitting {

template <int P>
using MatP = Eigen::Matrix<double, P, P>;
template <int P>
using VecP = Eigen::Matrix<double, P, 1>;

// rho(s) and rho'(s) of s = |r|^2, as Ceres defines its losses (HuberLoss, CauchyLoss).
struct RobustLoss {
  FitLoss kind;
  double a;
  void eval(double s, double* rho, double* w) const {
    switch (kind) {
      case FitLoss::kHuber:
        if (s > a * a) {
          const double r = std::sqrt(s);
          *rho = 2 * a * r - a * a;
          *w = a / r;
          return;
        }
        break;
      case FitLoss::kCauchy: {
        const double c = 1 / (a * a);
        *rho = a * a * std::log1p(s * c);
        *w = 1 / (1 + s * c);
        return;
      }
      case FitLoss::kNone:
        break;
    }
    *rho = s;
    *w = 1;
  }
  // The coefficient of the curvature the weight w leaves out at s (HuberCurvature): outside Huber's
  // quadratic core w / s, times the ramp min(1, |r| / a - 1); else 0.
  double huber_curvature(double s, double w) const {
    if (kind != FitLoss::kHuber || s <= a * a) return 0.0;
    return w / s * std::min(1.0, std::sqrt(s) / a - 1);
  }
};

template <int P>
struct FusedSums {
  MatP<P> H = MatP<P>::Zero();  // J^T W J (upper triangle until the pass ends)
  MatP<P> C = MatP<P>::Zero();  // the curvature W leaves out (HuberCurvature), likewise
  VecP<P> g = VecP<P>::Zero();  // J^T W r
  double cost = 0, rss = 0;
  bool finite = true;
  // The matrix of the steps: the cost's Gauss-Newton curvature (H stays the reweighting's, which
  // the covariance and the steps' size in sigmas use, as Ceres' covariance of the same loss does).
  MatP<P> step_matrix() const { return H - C; }
};

// One observation's residual r[3] and Jacobian rows (d k_d[k], d k_s[k], shared[k][0 .. P-7]).
template <int P>
struct ObsRow {
  double r[3], dkd[3], dks[3], shared[3][P - 6];
};

// Huber's curvature that the reweighting leaves out. Outside its quadratic core Huber's rho(|r|^2)
// grows as |r|, which has no curvature along r: there an observation's exact Gauss-Newton matrix
// is rho' J^T (I - r r^T / |r|^2) J, not the rho' J^T J that the weights give (and that Ceres uses
// too, since Huber's rho'' < 0). Both share the gradient, so the minimum. Where many observations
// lie outside the core (a model that does not describe the sample, as a global fit of a swirled
// plate), steps with the weights' matrix converge only linearly. An observation just outside the
// core may step back into it, where the curvature along r is whole again: the part taken away
// grows from none at |r| = a to all of it at |r| >= 2a (docs/solver-rules.md "Huber's curvature").
// Summed here: f (rho' / |r|^2) u u^T with u = sum_k r_k J_k and f = min(1, |r| / a - 1) (upper
// triangle), taken from J^T W J for the steps.
template <int P>
struct HuberCurvature {
  static constexpr int kTri = P * (P + 1) / 2;
  double c[kTri] = {};

  void add(const ObsRow<P>& d, double coef) {
    if (coef == 0) return;
    double u[P];
    for (int k = 0; k < 3; ++k) u[k] = d.r[k] * d.dkd[k], u[3 + k] = d.r[k] * d.dks[k];
    for (int j = 0; j < P - 6; ++j)
      u[6 + j] = d.r[0] * d.shared[0][j] + d.r[1] * d.shared[1][j] + d.r[2] * d.shared[2][j];
    int t = 0;
    for (int a = 0; a < P; ++a) {
      const double cu = coef * u[a];
      for (int b = a; b < P; ++b) c[t++] += cu * u[b];
    }
  }

  void scatter(FusedSums<P>* s) const {
    int t = 0;
    for (int a = 0; a < P; ++a)
      for (int b = a; b < P; ++b) s->C(a, b) += c[t++];
  }
};

// A chunk's sums while it runs: per channel k, the upper triangle of J^T W J and J^T W r over that
// channel's nonzero columns (k_d[k], k_s[k], the shared ones) at fixed places, so the per-pixel
// update is straight-line code; scattered into the P x P sums once per chunk.
template <int P>
struct ChannelSums {
  static constexpr int kNz = P - 4, kTri = kNz * (kNz + 1) / 2;
  double h[3][kTri] = {}, g[3][kNz] = {};
  double cost = 0, rss = 0;

  // With `jac` and `curv`, also Huber's curvature of the observation.
  void add(const ObsRow<P>& d, const RobustLoss& loss, bool jac,
           HuberCurvature<P>* curv = nullptr) {
    const double r2 = d.r[0] * d.r[0] + d.r[1] * d.r[1] + d.r[2] * d.r[2];
    double rho, w;
    loss.eval(r2, &rho, &w);
    cost += rho;
    rss += w * r2;
    if (!jac) return;
    if (curv) curv->add(d, loss.huber_curvature(r2, w));
    for (int k = 0; k < 3; ++k) {
      double v[kNz];
      v[0] = d.dkd[k], v[1] = d.dks[k];
      for (int j = 0; j < P - 6; ++j) v[2 + j] = d.shared[k][j];
      int t = 0;
      for (int a = 0; a < kNz; ++a) {
        const double wv = w * v[a];
        g[k][a] += wv * d.r[k];
        for (int b = a; b < kNz; ++b) h[k][t++] += wv * v[b];
      }
    }
  }

  // Adds these sums to s (H's upper triangle).
  void scatter(FusedSums<P>* s) const {
    s->cost += cost;
    s->rss += rss;
    for (int k = 0; k < 3; ++k) {
      int col[kNz];
      col[0] = k, col[1] = 3 + k;
      for (int j = 0; j < P - 6; ++j) col[2 + j] = 6 + j;
      int t = 0;
      for (int a = 0; a < kNz; ++a) {
        s->g(col[a]) += g[k][a];
        for (int b = a; b < kNz; ++b) s->H(col[a], col[b]) += h[k][t++];
      }
    }
  }
};

// Observations per chunk of a pass: each chunk sums alone, the chunks are added in order.
constexpr size_t kFusedChunk = 4096;

// One pass over n observations in fixed chunks: `chunk(begin, end, &sums, &curvature)` adds
// observations [begin, end) to a chunk's sums (and, with `jac`, Huber's curvature).
template <int P, class Chunk>
FusedSums<P> fused_pass_chunks(size_t n, bool jac, tbb::task_arena* arena, const Chunk& chunk) {
  const size_t chunks = (n + kFusedChunk - 1) / kFusedChunk;
  std::vector<FusedSums<P>> part(chunks);
  arena->execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t c = r.begin(); c < r.end(); ++c) {
                          ChannelSums<P> sums;
                          HuberCurvature<P> curv;
                          chunk(c * kFusedChunk, std::min(n, (c + 1) * kFusedChunk), &sums, &curv);
                          sums.scatter(&part[c]);
                          if (jac) curv.scatter(&part[c]);
                        }
                      });
  });
  FusedSums<P> s;
  for (const FusedSums<P>& q : part) {
    s.cost += q.cost;
    s.rss += q.rss;
    if (!jac) continue;
    s.H += q.H;
    s.C += q.C;
    s.g += q.g;
  }
  s.H = s.H.template selfadjointView<Eigen::Upper>();
  s.C = s.C.template selfadjointView<Eigen::Upper>();
  s.finite =
      std::isfinite(s.cost) && (!jac || (s.H.allFinite() && s.C.allFinite() && s.g.allFinite()));
  return s;
}

// One pass over n observations: `row(j, &d)` gives observation j's residual and rows. Without
// Huber's curvature (the fiber model's pass): the fiber model's steps are mostly rejected or damped
// hard where it would count, and it took more steps with it (docs/solver-rules.md "Huber's
// curvature").
template <int P, class Row>
FusedSums<P> fused_pass(size_t n, const RobustLoss& loss, bool jac, tbb::task_arena* arena,
                        const Row& row) {
  return fused_pass_chunks<P>(n, jac, arena,
                              [&](size_t begin, size_t end, ChannelSums<P>* s, HuberCurvature<P>*) {
                                ObsRow<P> d;
                                for (size_t j = begin; j < end; ++j) {
                                  row(j, &d);
                                  s->add(d, loss, jac);
                                }
                              });
}

// The diagonal of H^-1 (one factorisation, every column at once).
template <int P>
VecP<P> inverse_diagonal(const MatP<P>& H) {
  return Eigen::LDLT<MatP<P>>(H).solve(MatP<P>::Identity()).diagonal();
}

// The largest coordinate of `step` in units of that coordinate's standard error at the current
// point (H^-1 s^2 with s^2 = rss / (values - P)), from the diagonal of H^-1.
template <int P>
double step_in_sigmas_d(const VecP<P>& hinv, const VecP<P>& step, double rss, double values) {
  const double s2 = rss / std::max(1.0, values - P);
  double worst = 0;
  for (int k = 0; k < P; ++k) {
    const double var = hinv(k) * s2;
    if (var > 0 && std::isfinite(var)) worst = std::max(worst, std::abs(step(k)) / std::sqrt(var));
  }
  return worst;
}

template <int P>
double step_in_sigmas_p(const MatP<P>& H, const VecP<P>& step, double rss, double values) {
  return step_in_sigmas_d<P>(inverse_diagonal<P>(H), step, rss, values);
}

// Converged: no coordinate of the next step would move by this much of its standard error.
constexpr double kStepInSigma = 1e-3;
constexpr double kLastStepInSigma = 0.1;

// A ridge: where k_s and n trade off (a lobe seen only on its flank), a texel's LM crawls along
// them, each step a little lower, to its iteration limit, while k_d and psi (and s) stay put. Past
// kRidgeIterations, a texel whose k_d, psi (and s) moved less than kRidgeSettledSigma of their
// sigma over the last kRidgeWindow accepted steps is done: k_s and n keep the sigma the ridge gives
// them (named where it passes their bounds' spread). The line model's texel LM
// (fit/maps/texel_line.cpp) and the fiber model's texels through fused_lm's `ridge_rule`.
constexpr int kRidgeIterations = 30, kRidgeWindow = 10;
constexpr double kRidgeSettledSigma = 0.1;

// Where Gauss-Newton converges only linearly (a model that does not describe the data, or the
// robust weights still moving), consecutive steps point the same way and shrink by a steady ratio
// r: the rest of that geometric series, step / (1 - r), is tried first, and kept only if it
// lowers the cost (else the plain step is taken). Direction and ratio in the metric of diag(H). A
// ratio above kMaxRatio is taken as kMaxRatio (a jump of 100 steps, not an unbounded one).
template <int P>
bool extrapolate(const MatP<P>& H, const VecP<P>& step, const VecP<P>& prev, VecP<P>* trial) {
  constexpr double kSameDirection = 0.98, kMaxRatio = 0.99, kMinRatio = 0.05;
  const VecP<P> d = H.diagonal().cwiseMax(1e-300).cwiseSqrt();
  const VecP<P> a = d.cwiseProduct(step), b = d.cwiseProduct(prev);
  const double na = a.norm(), nb = b.norm();
  if (!(na > 0 && nb > 0)) return false;
  const double r = na / nb;
  if (a.dot(b) < kSameDirection * na * nb || r >= 1 || r < kMinRatio) return false;
  *trial = step / (1 - std::min(r, kMaxRatio));
  return true;
}

// Nielsen's rule for lambda (Madsen, Nielsen & Tingleff, "Methods for non-linear least squares
// problems", 2004, §3.2): after an accepted step lambda *= max(1/3, 1 - (2 rho - 1)^3), rho the
// decrease over the one the linear model predicts; after a rejected one lambda *= nu, nu doubling.
// Steady where the model holds, not the halving of the accepted steps that a fixed /10, *10 gave
// in a curved valley (a fiber texel ran out of its 100 iterations that way, 50 accepted, 50
// rejected, where Ceres took 37).
struct NielsenDamping {
  double lambda = 1e-4, nu = 2;
  // The step from `from` (sums `at`) to `to` lowered the cost to `cost`.
  template <int P>
  void accepted(const FusedSums<P>& at, const VecP<P>& from, const VecP<P>& to, double cost) {
    VecP<P> d = to - from;
    if constexpr (P > 7) d(7) -= M_PI * std::round(d(7) / M_PI);  // psi's step, not its wrap
    const double predicted = -2 * at.g.dot(d) - d.dot(at.step_matrix() * d);
    const double rho = predicted > 0 ? (at.cost - cost) / predicted : 1.0;
    lambda = std::max(lambda * std::max(1.0 / 3, 1 - std::pow(2 * rho - 1, 3)), 1e-12);
    nu = 2;
  }
  void rejected() { lambda *= nu, nu *= 2; }
};

// The damped step from the sums at the current point: with the cost's Gauss-Newton curvature
// (FusedSums::step_matrix), or with J^T W J where that one is not positive definite once damped.
// Damped by lambda times the diagonal floored at kMinDiagonal, Ceres' min_diagonal (the texels' LM
// in fit/maps/texel_line.cpp uses the same floor).
constexpr double kMinDiagonal = 1e-6;
template <int P>
VecP<P> lm_step(const FusedSums<P>& s, double lambda) {
  // The floor: a column the data hardly see (n where a lobe lights next to no pixel) is damped
  // too, as Ceres damps it; global fits have no column that small (docs/solver-rules.md "The
  // damping floor").
  auto damped = [lambda](MatP<P> a) {
    a.diagonal() += lambda * a.diagonal().cwiseMax(kMinDiagonal);
    return a;
  };
  const Eigen::LDLT<MatP<P>> f(damped(s.step_matrix()));
  if (f.info() == Eigen::Success && (f.vectorD().array() > 0).all()) {
    const VecP<P> step = f.solve(-s.g);
    if (step.allFinite()) return step;
  }
  return damped(s.H).ldlt().solve(-s.g);
}

// The step with the coordinates at a bound held there: a coordinate at its bound whose step points
// out of the box is fixed (its row and column of both matrices and its gradient taken out) and the
// step solved again for the others, until no free coordinate's step points out at its bound. A
// step clipped at the bound instead is not the reduced problem's step: the rest of it is wrong by
// the coupling, the step is often rejected, and its size never falls under kStepInSigma. psi
// (coordinate 7) wraps and has no bound. A coordinate whose bounds are equal is held from the
// start (a psi held at a value). Test: FitSolvers.AFitAtABoundConverges.
template <int P>
VecP<P> lm_step_in_box(const FusedSums<P>& s, double lambda, const VecP<P>& x, const VecP<P>& lo,
                       const VecP<P>& hi) {
  FusedSums<P> r = s;
  bool held[P] = {};
  for (int k = 0; k < P; ++k) held[k] = lo(k) == hi(k);
  // First the coordinates whose gradient points out (the cost falls outward), then those the
  // reduced step pushes out.
  VecP<P> step = -s.g;
  for (int round = 0; round <= P; ++round) {
    bool more = false;
    for (int k = 0; k < P; ++k) {
      if (k == 7 || held[k]) continue;
      if ((x(k) <= lo(k) && step(k) < 0) || (x(k) >= hi(k) && step(k) > 0)) held[k] = more = true;
    }
    if (!more && round > 0) break;
    for (int k = 0; k < P; ++k) {
      if (!held[k]) continue;
      r.H.row(k).setZero(), r.H.col(k).setZero(), r.C.row(k).setZero(), r.C.col(k).setZero();
      r.H(k, k) = 1, r.g(k) = 0;
    }
    step = lm_step<P>(r, lambda);
    for (int k = 0; k < P; ++k)
      if (held[k]) step(k) = 0;
  }
  return step;
}

// The Levenberg-Marquardt loop from *x (updated) within [lo, hi] (psi, coordinate 7, wrapped):
// `pass(x, jac)` returns the sums at x. *cur ends as the sums at the solution.
// With `ridge_rule`, a texel's: done on a ridge (kRidgeIterations), its steps clipped at the
// bounds rather than held there and no crawl rule: a texel's pull and retries are tuned to those
// (held, one fiber texel of 133 moved 0.7 sigma between quadrature orders that otherwise agree to
// 4e-4 sigma: FitMaps.FiberTexelsTakeTheQuadratureOrderTheirValuesAllow). `lambda0`: the first
// step's damping.
template <int P, class Pass>
void fused_lm(const Pass& pass, const VecP<P>& lo, const VecP<P>& hi, double values,
              int max_iterations, VecP<P>* x, FusedSums<P>* cur, FusedSolve* out,
              bool ridge_rule = false, double lambda0 = NielsenDamping().lambda) {
  constexpr double kRelativeDecrease = 1e-14;
  constexpr double kLambdaMax = 1e12;
  *x = x->cwiseMax(lo).cwiseMin(hi);
  *cur = pass(*x, true);
  out->passes = 1;
  if (out->record_costs) out->costs.assign(1, cur->cost);
  NielsenDamping damp;
  damp.lambda = lambda0;
  VecP<P> prev = VecP<P>::Zero();  // the last plain step taken
  double last = 0;                 // its size in sigmas (0: none yet)
  auto to = [&](const VecP<P>& s) {
    VecP<P> xn = (*x + s).cwiseMax(lo).cwiseMin(hi);
    if constexpr (P > 7) xn(7) = wrap_half_turn(xn(7));
    return xn;
  };
  VecP<P> window_start = *x;  // the ridge rule's
  int accepted = 0;
  CrawlWatch crawl(cur->cost);
  for (int it = 0; it < max_iterations && cur->finite; ++it) {
    const VecP<P> step = ridge_rule ? lm_step<P>(*cur, damp.lambda)
                                    : lm_step_in_box<P>(*cur, damp.lambda, *x, lo, hi);
    // A step too small to matter is not taken (nor evaluated: at this size the cost's change is
    // rounding, and a rejected step would only raise lambda).
    const double size = step_in_sigmas_p<P>(cur->H, step, cur->rss, values);
    if (size < kStepInSigma) {
      out->converged = true;
      break;
    }
    VecP<P> trial, xn = to(step);
    // A last Gauss-Newton step is taken without a pass to confirm it where the steps show it
    // lands within kStepInSigma: under kLastStepInSigma, lambda small, inside the bounds, and
    // shrinking fast enough that even at the rate of the step before (size / last, linear: the
    // cautious reading of a quadratic convergence) what is left after it is under kStepInSigma.
    // The pass would only say so. J^T J and the sum of squares stay those of the point before
    // (they change by as little). Fiber-flat, full data: steps 5.4, 0.053 (left: 5e-4) sigma.
    if (size < kLastStepInSigma && size * size < kStepInSigma * last && damp.lambda <= 1e-3 &&
        xn == *x + step) {
      *x = xn;
      ++out->iterations;
      out->converged = true;
      break;
    }
    FusedSums<P> next;
    if (extrapolate<P>(cur->H, step, prev, &trial)) {
      const VecP<P> xt = to(trial);
      next = pass(xt, true);
      ++out->passes;
      if (next.finite && next.cost < cur->cost)
        xn = xt;
      else
        next = pass(xn, true), ++out->passes;
    } else {
      next = pass(xn, true);
      ++out->passes;
    }
    if (next.finite && next.cost < cur->cost) {
      damp.accepted<P>(*cur, *x, xn, next.cost);
      prev = step;
      last = size;
      const bool small_decrease = cur->cost - next.cost <= kRelativeDecrease * cur->cost;
      *x = xn;
      *cur = next;
      ++out->iterations;
      if (out->record_costs) out->costs.push_back(cur->cost);
      if (small_decrease) {
        out->converged = true;
        break;
      }
      if (!ridge_rule && crawl.accepted(cur->cost, cur->rss / std::max(1.0, values - P))) {
        out->converged = out->crawled = true;
        break;
      }
      if (ridge_rule && ++accepted % kRidgeWindow == 0) {
        VecP<P> moved = *x - window_start;
        moved.template segment<4>(3).setZero();  // k_s, log n: the ridge
        if constexpr (P > 7) moved(7) = std::remainder(moved(7), M_PI);
        if (it >= kRidgeIterations &&
            step_in_sigmas_p<P>(cur->H, moved, cur->rss, values) < kRidgeSettledSigma) {
          out->converged = true;
          break;
        }
        window_start = *x;
      }
    } else {
      prev.setZero();
      last = 0;
      damp.rejected();
      if (damp.lambda > kLambdaMax) {
        out->converged = true;  // no step lowers the cost: a minimum to the precision of doubles
        break;
      }
    }
  }
  out->info.resize(static_cast<size_t>(P) * P);
  Eigen::Map<Eigen::Matrix<double, P, P, Eigen::RowMajor>>(out->info.data()) = cur->H;
  out->rss = cur->rss;
  out->cost = cur->cost;
}

}  // namespace aniso::fitting
