#include "fit/global/view_sandwich.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "fit/solvers/model_fit.h"

namespace aniso::fitting {

std::vector<double> per_view_covariance(ModelFit* m, const ObsSet& os,
                                        const std::vector<std::pair<double*, int>>& blocks,
                                        const std::vector<double>& ainv, int threads,
                                        size_t* views_used, bool differences) {
  *views_used = 0;
  const size_t G = os.view_lights.size(), N = os.obs.size();
  std::vector<double*> coords;
  for (const auto& [b, size] : blocks)
    for (int k = 0; k < size; ++k) coords.push_back(b + k);
  const size_t P = coords.size();
  if (G < P + 2 || P == 0 || ainv.size() != P * P || N > kMaxObservations) return {};
  // Each observation's view, from the first of its lights.
  auto view_of = [&](size_t i) {
    const auto it = std::upper_bound(os.view_lights.begin(), os.view_lights.end(),
                                     static_cast<size_t>(os.obs[i].first_light));
    return static_cast<size_t>(it - os.view_lights.begin()) - 1;
  };
  tbb::task_arena arena(std::max(1, threads));
  auto each = [&](auto&& f) {  // f(i, residual of i) over every observation, in parallel
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, N, 4096),
                        [&](const tbb::blocked_range<size_t>& r) {
                          double res[3];
                          for (size_t i = r.begin(); i < r.end(); ++i) {
                            m->residual(os, i, res);
                            f(i, res);
                          }
                        });
    });
  };
  std::vector<size_t> count(G, 0);
  for (size_t i = 0; i < N; ++i) ++count[view_of(i)];
  std::vector<double> g(G * P, 0.0);
  // Where the model gives its rows (ModelFit::residual_row), g in one pass: each coordinate's
  // column in a row (k_d[c] and k_s[c] in channel c's alone, the shared ones in every channel).
  // The fiber model's: one pass of its fused solver where the differences below take 2P + 1.
  // Both ways agree to the differences' precision:
  // FitSolvers.TheViewsSpreadFromRowsAsFromDifferences.
  std::vector<int> column(P, -1);  // 0-2 k_d[c], 3-5 k_s[c], 6 + j shared j
  const std::vector<const double*> shared = m->row_shared();
  for (size_t k = 0; k < P; ++k) {
    for (int c = 0; c < 3; ++c) {
      if (coords[k] == &m->core.kd[c]) column[k] = c;
      if (coords[k] == &m->core.ks[c]) column[k] = 3 + c;
    }
    for (size_t j = 0; j < shared.size(); ++j)
      if (coords[k] == shared[j]) column[k] = 6 + static_cast<int>(j);
  }
  const bool rows = !differences && !shared.empty() &&
                    std::all_of(column.begin(), column.end(), [](int c) { return c >= 0; });
  // Sums over fixed chunks of observations, each a few views' partial sums, added in the chunks'
  // order: the same bits whatever the threads (a run's σ repeat to the last digit).
  constexpr size_t kChunk = 4096;
  const size_t chunks = (N + kChunk - 1) / kChunk;
  struct ChunkSums {
    std::vector<size_t> views;  // the views the chunk's observations are of, as met
    std::vector<double> sums;   // width values per view, in that order
  };
  auto in_chunks = [&](size_t width, auto&& add) {  // add(i, sums of i's view in its chunk)
    std::vector<ChunkSums> part(chunks);
    arena.execute([&] {
      tbb::parallel_for(size_t(0), chunks, [&](size_t c) {
        ChunkSums& cs = part[c];
        for (size_t i = c * kChunk; i < std::min(N, (c + 1) * kChunk); ++i) {
          const size_t v = view_of(i);
          if (cs.views.empty() || cs.views.back() != v) {
            cs.views.push_back(v);
            cs.sums.resize(cs.sums.size() + width, 0.0);
          }
          add(i, &cs.sums[cs.sums.size() - width]);
        }
      });
    });
    return part;
  };
  if (rows) {
    const auto part = in_chunks(P, [&](size_t i, double* gv) {
      double r[3], dkd[3], dks[3], sh[3][3];
      m->residual_row(os, i, r, dkd, dks, sh);
      for (size_t k = 0; k < P; ++k) {
        const int col = column[k];
        if (col < 3)
          gv[k] += r[col] * dkd[col];
        else if (col < 6)
          gv[k] += r[col - 3] * dks[col - 3];
        else
          gv[k] += r[0] * sh[0][col - 6] + r[1] * sh[1][col - 6] + r[2] * sh[2][col - 6];
      }
    });
    for (const ChunkSums& cs : part)
      for (size_t j = 0; j < cs.views.size(); ++j)
        for (size_t k = 0; k < P; ++k) g[cs.views[j] * P + k] += cs.sums[j * P + k];
  }
  // The residuals at the solution (float: only weights below, the same in both differences).
  std::vector<float> r0(rows ? 0 : 3 * N);
  if (!rows)
    each([&](size_t i, const double* res) {
      for (int c = 0; c < 3; ++c) r0[3 * i + c] = static_cast<float>(res[c]);
    });
  // Otherwise g[v * P + k]: view v's sum over its pixels and channels of dr/dtheta_k times r, as
  // (sum r(theta + h) r0 - sum r(theta - h) r0) / 2h: linear in r, so each side is one pass that
  // keeps nothing per observation. Moving a coordinate is shared state: it is set before each
  // pass and restored after the two.
  for (size_t k = 0; k < P && !rows; ++k) {
    double* x = coords[k];
    const double x0 = *x, h = 1e-5 * std::max(1.0, std::abs(x0));
    for (int side = 0; side < 2; ++side) {
      *x = side == 0 ? x0 + h : x0 - h;
      const auto part = in_chunks(1, [&](size_t i, double* s) {
        double res[3];
        m->residual(os, i, res);
        double t = 0;
        for (int c = 0; c < 3; ++c) t += res[c] * r0[3 * i + c];
        *s += t;
      });
      const double sign = side == 0 ? 1 / (2 * h) : -1 / (2 * h);
      for (const ChunkSums& cs : part)
        for (size_t j = 0; j < cs.views.size(); ++j) g[cs.views[j] * P + k] += sign * cs.sums[j];
    }
    *x = x0;
  }
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(P, P);
  size_t used = 0;
  for (size_t v = 0; v < G; ++v) {
    if (count[v] == 0) continue;
    ++used;
    const Eigen::Map<const Eigen::VectorXd> gv(&g[v * P], P);
    B += gv * gv.transpose();
  }
  if (used < P + 2) return {};
  *views_used = used;
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> A(
      ainv.data(), P, P);
  const Eigen::MatrixXd C =
      (static_cast<double>(used) / static_cast<double>(used - P)) * (A * B * A.transpose());
  std::vector<double> out(P * P);
  for (size_t r = 0; r < P; ++r)
    for (size_t c = 0; c < P; ++c) out[r * P + c] = C(r, c);
  return out;
}

}  // namespace aniso::fitting
