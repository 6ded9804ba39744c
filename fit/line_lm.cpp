#include "fit/line_lm.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "fit/line_pixel.h"
#include "models/params.h"

namespace aniso::fitting {

namespace {

// rho(s) and rho'(s) of s = |r|^2, as Ceres defines its losses (HuberLoss, CauchyLoss).
struct Loss {
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
};

struct Sums {
  Mat8 H = Mat8::Zero();  // J^T W J
  Vec8 g = Vec8::Zero();  // J^T W r
  double cost = 0, rss = 0;
  bool finite = true;
};

// Observations per chunk of a pass: each chunk sums alone, the chunks are added in order.
constexpr size_t kChunk = 4096;

void accumulate(const ObsSet& os, size_t i, const LinePixelParams& p, const Loss& loss, bool jac,
                Sums* s) {
  PixelDerivs d;
  line_pixel_derivs(os.obs[i], os.lights.data(), p, &d);
  const double r2 = d.r[0] * d.r[0] + d.r[1] * d.r[1] + d.r[2] * d.r[2];
  double rho, w;
  loss.eval(r2, &rho, &w);
  s->cost += rho;
  s->rss += w * r2;
  if (!jac) return;
  for (int k = 0; k < 3; ++k) {
    // Row k of J: d k_d[k] at column k, d k_s[k] at 3 + k, d log n at 6, d psi at 7.
    const int col[4] = {k, 3 + k, 6, 7};
    const double v[4] = {d.dkd[k], d.dks[k], d.dlogn[k], d.dpsi[k]};
    for (int a = 0; a < 4; ++a) {
      const double wv = w * v[a];
      s->g(col[a]) += wv * d.r[k];
      for (int b = a; b < 4; ++b) s->H(col[a], col[b]) += wv * v[b];
    }
  }
}

// One pass at x: the robust cost and, with `jac`, J^T W J and J^T W r (W at x).
Sums pass(const ObsSet& os, const std::vector<size_t>* subset, const Vec8& x, const Loss& loss,
          bool jac, tbb::task_arena* arena) {
  const size_t n = subset ? subset->size() : os.obs.size();
  const size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<Sums> part(chunks);
  const double kd[3] = {x(0), x(1), x(2)}, ks[3] = {x(3), x(4), x(5)};
  const LinePixelParams p{kd, ks, std::exp(x(6)), std::cos(x(7)), std::sin(x(7))};
  arena->execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t c = r.begin(); c < r.end(); ++c) {
                          const size_t end = std::min(n, (c + 1) * kChunk);
                          for (size_t j = c * kChunk; j < end; ++j)
                            accumulate(os, subset ? (*subset)[j] : j, p, loss, jac, &part[c]);
                        }
                      });
  });
  Sums s;
  for (const Sums& q : part) {
    s.cost += q.cost;
    s.rss += q.rss;
    if (!jac) continue;
    s.H += q.H;
    s.g += q.g;
  }
  s.H = s.H.selfadjointView<Eigen::Upper>();
  s.finite = std::isfinite(s.cost) && (!jac || (s.H.allFinite() && s.g.allFinite()));
  return s;
}

}  // namespace

Vec8 pack_core(const Core& c) {
  Vec8 x;
  x << c.kd[0], c.kd[1], c.kd[2], c.ks[0], c.ks[1], c.ks[2], c.logn, c.psi;
  return x;
}

void unpack_core(const Vec8& x, Core* c) {
  for (int k = 0; k < 3; ++k) c->kd[k] = x(k), c->ks[k] = x(3 + k);
  c->logn = x(6);
  c->psi = x(7);
}

void core_bounds(Vec8* lo, Vec8* hi) {
  for (int k = 0; k < 3; ++k) {
    (*lo)(k) = line_param("kd").lo, (*hi)(k) = line_param("kd").hi;
    (*lo)(3 + k) = line_param("ks").lo, (*hi)(3 + k) = line_param("ks").hi;
  }
  (*lo)(6) = std::log(line_param("n").lo), (*hi)(6) = std::log(line_param("n").hi);
  (*lo)(7) = -INFINITY, (*hi)(7) = INFINITY;
}

double step_in_sigmas(const Mat8& H, const Vec8& step, double rss, double values) {
  const double s2 = rss / std::max(1.0, values - 8);
  const Eigen::LDLT<Mat8> ldlt(H);
  double worst = 0;
  for (int k = 0; k < 8; ++k) {
    Vec8 e = Vec8::Zero();
    e(k) = 1;
    const double var = ldlt.solve(e)(k) * s2;
    if (var > 0 && std::isfinite(var)) worst = std::max(worst, std::abs(step(k)) / std::sqrt(var));
  }
  return worst;
}

void line_lm_solve(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss_kind,
                   double scale, int max_iterations, int threads, Core* c, FusedSolve* out) {
  constexpr double kRelativeDecrease = 1e-14;
  constexpr double kLambdaMax = 1e12;
  tbb::task_arena arena(std::max(1, threads));
  const Loss loss{loss_kind, scale};
  const double values = 3.0 * static_cast<double>(subset ? subset->size() : os.obs.size());
  Vec8 lo, hi;
  core_bounds(&lo, &hi);
  Vec8 x = pack_core(*c).cwiseMax(lo).cwiseMin(hi);
  Sums cur = pass(os, subset, x, loss, true, &arena);
  out->passes = 1;
  double lambda = 1e-4;
  for (int it = 0; it < max_iterations && cur.finite; ++it) {
    Mat8 a = cur.H;
    a.diagonal() += lambda * cur.H.diagonal().cwiseMax(1e-300);
    const Vec8 step = a.ldlt().solve(-cur.g);
    Vec8 xn = (x + step).cwiseMax(lo).cwiseMin(hi);
    xn(7) = wrap_half_turn(xn(7));
    // A step too small to matter is not taken (nor evaluated: at this size the cost's change is
    // rounding, and a rejected step would only raise lambda).
    if (step_in_sigmas(cur.H, step, cur.rss, values) < kStepInSigma) {
      out->converged = true;
      break;
    }
    Sums next = pass(os, subset, xn, loss, true, &arena);
    ++out->passes;
    if (next.finite && next.cost < cur.cost) {
      const bool small_decrease = cur.cost - next.cost <= kRelativeDecrease * cur.cost;
      x = xn;
      cur = next;
      ++out->iterations;
      lambda = std::max(lambda / 10, 1e-12);
      if (small_decrease) {
        out->converged = true;
        break;
      }
    } else {
      lambda *= 10;
      if (lambda > kLambdaMax) {
        out->converged = true;  // no step lowers the cost: a minimum to the precision of doubles
        break;
      }
    }
  }
  unpack_core(x, c);
  Eigen::Map<Eigen::Matrix<double, 8, 8, Eigen::RowMajor>>(out->info) = cur.H;
  out->rss = cur.rss;
  out->cost = cur.cost;
}

}  // namespace aniso::fitting
