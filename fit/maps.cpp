// --maps: per-texel maps of the line model (issue 11). The observations are binned by the texel
// their texture coordinates fall in; each texel is its own small problem (8 numbers: k_d, k_s,
// log n, psi), started from a grid over psi with k_d, k_s in closed form at the global fit's n,
// solved by Ceres (the fitter of record) and given sigmas from its normal equations. A texel
// whose data do not determine it keeps the global values, marked, with the prior's spread as its
// sigma: never a confident number it did not earn.
#include "fit/maps.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/angles.h"
#include "core/progress.h"
#include "fit/line_lm.h"
#include "fit/line_pixel.h"
#include "fit/start.h"
#include "models/params.h"

namespace aniso::fitting {

namespace {

constexpr size_t kMinTexelPixels = 12;      // fewer: not even tried
constexpr double kPsiUndeterminedDeg = 10;  // sigma of psi above this: the direction is not known
constexpr double kConditionLimit = 1e-12;   // smallest / largest eigenvalue, column-scaled

double prior_sigma(const char* key) {
  const ParamSpec& p = line_param(key);
  return (p.hi - p.lo) / std::sqrt(12.0);
}

// Grid over psi with k_d, k_s in closed form at the power of two nearest the global n (x^n by
// squaring: this grid was most of the texel phase with a pow per pixel): the texel's start.
void texel_start(const ObsSet& os, const std::vector<size_t>& idx, Core* c) {
  const int log2n = std::clamp(static_cast<int>(std::lround(c->logn / std::log(2.0))), 1, 12);
  double best = INFINITY;
  for (int ip = 0; ip < 36; ++ip) {
    const double psi = ip * M_PI / 36;
    double kd[3], ks[3];
    const double cost = line_node_cost(os, idx, psi, log2n, kd, ks);
    if (cost < best) {
      best = cost;
      c->psi = psi;
      set_start_kd_ks(kd, ks, c);
    }
  }
}

struct TexelResult {
  Core c;
  double sigma[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // kd 3, ks 3, log n, psi
  bool determined = false;
  double rss = 0, values = 0;
};

// sigmas from J^T J (`info`) and the residual sum of squares at the solution: the rank test on
// the eigenvalues of the column-scaled matrix, then the diagonal of its inverse times s^2.
void texel_sigmas(const Mat8& info, double rss, double values, TexelResult* t) {
  t->rss = rss;
  t->values = values;
  const double dof = values - 8;
  if (dof < 1) return;
  const double s2 = rss / dof;
  Vec8 scale;
  for (int k = 0; k < 8; ++k) scale(k) = info(k, k) > 0 ? 1 / std::sqrt(info(k, k)) : 0;
  const Mat8 scaled = scale.asDiagonal() * info * scale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Mat8> eig(scaled);
  const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
  if (!(scale.minCoeff() > 0) || !(lo > kConditionLimit * hi)) return;
  const Mat8 cov = scale.asDiagonal() * eig.eigenvectors() *
                   eig.eigenvalues().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose() *
                   scale.asDiagonal();
  for (int k = 0; k < 8; ++k) t->sigma[k] = std::sqrt(std::max(cov(k, k), 0.0) * s2);
  t->determined = rad_to_deg(t->sigma[7]) < kPsiUndeterminedDeg;
}

// One texel with Ceres (the fitter of record): solve, then J^T J of its own problem.
TexelResult solve_texel_ceres(const ObsSet& os, const std::vector<size_t>& idx,
                              const Core& global) {
  TexelResult t;
  t.c = global;
  texel_start(os, idx, &t.c);
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem pb(po);
  double dummy[2] = {0, 0};
  Core& c = t.c;
  for (size_t i : idx)
    pb.AddResidualBlock(line_pixel_cost(&os.obs[i], os.lights.data()), nullptr, c.kd, c.ks, &c.logn,
                        &c.psi, &dummy[0], &dummy[1]);
  pb.SetParameterBlockConstant(&dummy[0]);
  pb.SetParameterBlockConstant(&dummy[1]);
  set_core_bounds(&pb, &c);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 100;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  // Converged as far as double precision takes it, as the LM path: the reference to compare with.
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &pb, &sum);
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = {c.kd, c.ks, &c.logn, &c.psi};
  double cost = 0;
  ceres::CRSMatrix J;
  if (!pb.Evaluate(eo, &cost, nullptr, nullptr, &J) || J.num_cols != 8) return t;
  Mat8 info = Mat8::Zero();
  for (int r = 0; r < J.num_rows; ++r)
    for (int a = J.rows[r]; a < J.rows[r + 1]; ++a)
      for (int b = J.rows[r]; b < J.rows[r + 1]; ++b)
        info(J.cols[a], J.cols[b]) += J.values[a] * J.values[b];
  texel_sigmas(info, 2 * cost, J.num_rows, &t);
  return t;
}

// Sum of squares, and (info, grad) = (J^T J, J^T r) when asked, in one pass over the texel.
double texel_pass(const ObsSet& os, const std::vector<size_t>& idx, const Vec8& x, Mat8* info,
                  Vec8* grad) {
  if (info) info->setZero(), grad->setZero();
  double rss = 0;
  const double kd[3] = {x(0), x(1), x(2)}, ks[3] = {x(3), x(4), x(5)};
  const LinePixelParams p{kd, ks, std::exp(x(6)), std::cos(x(7)), std::sin(x(7))};
  for (size_t i : idx) {
    PixelDerivs d;
    line_pixel_derivs(os.obs[i], os.lights.data(), p, &d);
    for (int k = 0; k < 3; ++k) {
      rss += d.r[k] * d.r[k];
      if (!info) continue;
      // Row k of J: d k_d[k] at column k, d k_s[k] at 3 + k, d log n at 6, d psi at 7.
      const int col[4] = {k, 3 + k, 6, 7};
      const double v[4] = {d.dkd[k], d.dks[k], d.dlogn[k], d.dpsi[k]};
      for (int a = 0; a < 4; ++a) {
        (*grad)(col[a]) += v[a] * d.r[k];
        for (int b = 0; b < 4; ++b) (*info)(col[a], col[b]) += v[a] * v[b];
      }
    }
  }
  return rss;
}

// One texel with a hand-written Levenberg-Marquardt (the fast path of --maps): the same
// function (fit/line_pixel.h), the same bounds (projected) and the same start as the Ceres path;
// the tests check that both reach the same minimum.
TexelResult solve_texel_lm(const ObsSet& os, const std::vector<size_t>& idx, const Core& global) {
  TexelResult t;
  t.c = global;
  texel_start(os, idx, &t.c);
  Vec8 lo, hi;
  core_bounds(&lo, &hi);
  Vec8 x = pack_core(t.c), grad;
  Mat8 info;
  double rss = texel_pass(os, idx, x, &info, &grad), lambda = 1e-3;
  for (int it = 0; it < 100; ++it) {
    Mat8 a = info;
    a.diagonal() += lambda * info.diagonal().cwiseMax(1e-12);
    const Vec8 step = a.ldlt().solve(-grad);
    // The same stopping rule as the global fused solve: a step under 1e-3 sigma is not taken.
    if (step_in_sigmas(info, step, rss, 3.0 * idx.size()) < kStepInSigma) break;
    Vec8 xn = (x + step).cwiseMax(lo).cwiseMin(hi);
    xn(7) = wrap_half_turn(xn(7));
    const double rn = texel_pass(os, idx, xn, nullptr, nullptr);
    if (rn < rss) {
      const bool done = rss - rn <= 1e-12 * rss;
      x = xn;
      rss = texel_pass(os, idx, x, &info, &grad);
      lambda = std::max(lambda / 3, 1e-12);
      if (done) break;
    } else {
      lambda *= 4;
      if (lambda > 1e12) break;
    }
  }
  unpack_core(x, &t.c);
  texel_sigmas(info, rss, 3.0 * idx.size(), &t);
  return t;
}

}  // namespace

TexelMaps fit_texel_maps(const ObsSet& os, const Core& global, int w, int h, int row0, int row1,
                         bool ceres_path, bool progress) {
  const auto t0 = std::chrono::steady_clock::now();
  TexelMaps m;
  m.w = w;
  m.h = h;
  m.row0 = row0;
  m.row1 = row1;
  const size_t N = static_cast<size_t>(w) * h;
  std::vector<std::vector<size_t>> bins(N);
  for (size_t i = 0; i < os.obs.size(); ++i) {
    const double u = os.obs[i].u, v = os.obs[i].v;
    if (!(u >= 0 && u < 1 && v >= 0 && v < 1)) continue;
    bins[static_cast<size_t>(v * h) * w + static_cast<size_t>(u * w)].push_back(i);
  }
  m.kd.assign(3 * N, 0);
  m.ks.assign(3 * N, 0);
  m.kd_sigma.assign(3 * N, 0);
  m.ks_sigma.assign(3 * N, 0);
  m.n.assign(N, 0);
  m.psi_deg.assign(N, 0);
  m.n_sigma.assign(N, 0);
  m.psi_sigma_deg.assign(N, 0);
  m.pixels.assign(N, 0);
  m.determined.assign(N, 0);
  Progress bar("fit --maps: texels", N, progress);
  std::atomic<size_t> fitted{0};
  std::vector<double> rss(N, 0), values(N, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, N, 4), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t) {
      m.pixels[t] = static_cast<int>(bins[t].size());
      const int row = static_cast<int>(t / w);
      if (row < row0 || row >= row1) {  // another tile's
        bar.advance();
        continue;
      }
      TexelResult res;
      res.c = global;
      if (bins[t].size() >= kMinTexelPixels) {
        res = ceres_path ? solve_texel_ceres(os, bins[t], global)
                         : solve_texel_lm(os, bins[t], global);
        rss[t] = res.rss;
        values[t] = res.values;
        ++fitted;
      }
      m.determined[t] = res.determined;
      const Core& c = res.determined ? res.c : global;
      for (int k = 0; k < 3; ++k) {
        m.kd[3 * t + k] = c.kd[k];
        m.ks[3 * t + k] = c.ks[k];
        m.kd_sigma[3 * t + k] = res.determined ? res.sigma[k] : prior_sigma("kd");
        m.ks_sigma[3 * t + k] = res.determined ? res.sigma[3 + k] : prior_sigma("ks");
      }
      m.n[t] = std::exp(c.logn);
      m.n_sigma[t] = res.determined ? m.n[t] * res.sigma[6] : prior_sigma("n");
      m.psi_deg[t] = wrap_fiber_deg(rad_to_deg(c.psi));
      m.psi_sigma_deg[t] = res.determined ? rad_to_deg(res.sigma[7]) : 180 / std::sqrt(12.0);
      bar.advance();
    }
  });
  m.fitted = fitted;
  double sr = 0, sv = 0;
  for (size_t t = 0; t < N; ++t) sr += rss[t], sv += values[t];
  m.rms = sv > 0 ? std::sqrt(sr / sv) : 0;
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

}  // namespace aniso::fitting
