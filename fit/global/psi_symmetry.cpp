#include "fit/global/psi_symmetry.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "core/frame.h"
#include "core/timer.h"
#include "fit/records/observations.h"
#include "models/light.h"

namespace aniso::fitting {

namespace {

// One pixel: L and V in its frame, the value over the light's irradiance summed over the channels,
// and that sum's weight (1 / its variance for equal noise in each channel).
struct SymPixel {
  double L[3], V[3];
  double z, w;
  double robust = 1;  // Huber's weight at the coarse minimum
};

constexpr size_t kPixelsPerView = 6000;
// The lobe's table: kNodes x kNodes over u = s / (s + kSlopeScale) of each slope s in [0, inf),
// nodes evenly spread in u up to kMaxU (slopes past it share the last cell).
constexpr int kNodes = 12;
constexpr double kSlopeScale = 0.3, kMaxU = 0.9;
constexpr int kUnknowns = 1 + kNodes * kNodes;  // k_d, then the table
// The smoothness prior's weight relative to the data's mean diagonal over the table.
constexpr double kSmoothness = 1e-2;
// Pixels whose half vector or directions lie this near the horizon are left out (the lobe's
// 1 / (4 h_n^4 v_n) grows without bound there).
constexpr double kMinCos = 0.15;

std::vector<SymPixel> view_pixels(const CaptureSet& set, size_t i, GeometryCache* cache) {
  const ViewSpec& v = set.views[i];
  if (v.lights.size() != 1) return {};
  const ViewData d = load_view(set, i, nullptr, cache);
  std::vector<SymPixel> all;
  for_each_framed_pixel(d, [&](int x, int y, const SurfacePoint& sp) {
    Vec3 L;
    RGB E;
    double dist;
    if (!light_at(v.lights[0], sp.P, &L, &E, &dist)) return;
    const LocalDir l = to_local(sp, L), vv = to_local(sp, normalize(d.eye - sp.P));
    if (l.n < kMinCos || vv.n < kMinCos) return;
    SymPixel q{{l.u, l.w, l.n}, {vv.u, vv.w, vv.n}, 0, 0};
    double var = 0;
    bool ok = true;
    for (int k = 0; k < 3; ++k) {
      const double e = E[k] * v.exposure;
      if (!(e > 0)) ok = false;
      q.z += d.rgb.at(x, y, k) / e;
      var += 1 / (e * e);
    }
    if (!ok) return;
    q.w = 1 / var;
    all.push_back(q);
  });
  std::vector<SymPixel> out;
  for (size_t k : start_subset(all.size(), kPixelsPerView)) out.push_back(all[k]);
  return out;
}

// The node coordinate of a slope.
double node_of(double s) {
  const double u = s / (s + kSlopeScale);
  return std::min(u / kMaxU * (kNodes - 1), kNodes - 1 - 1e-9);
}

// One view's normal equations at psi: A (upper triangle), b, and the values' weighted sum of
// squares.
struct Normal {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  double c = 0;
};

// A pixel's row of the design at psi (cos c, sin s): its 5 nonzero columns and their values; false
// where its half vector is too near the horizon.
bool row_of(const SymPixel& q, double c, double s, int idx[5], double row[5]) {
  double H[3] = {q.L[0] + q.V[0], q.L[1] + q.V[1], q.L[2] + q.V[2]};
  const double len = std::sqrt(H[0] * H[0] + H[1] * H[1] + H[2] * H[2]);
  for (double& h : H) h /= len;
  if (H[2] < kMinCos) return false;
  const double ht = c * H[0] + s * H[1], hb = -s * H[0] + c * H[1];
  const double x = node_of(std::abs(ht) / H[2]), y = node_of(std::abs(hb) / H[2]);
  const int i0 = static_cast<int>(x), j0 = static_cast<int>(y);
  const double fx = x - i0, fy = y - j0;
  const double J = 1 / (4 * H[2] * H[2] * H[2] * H[2] * q.V[2]);
  const int at[5] = {0, 1 + j0 * kNodes + i0, 1 + j0 * kNodes + i0 + 1, 1 + (j0 + 1) * kNodes + i0,
                     1 + (j0 + 1) * kNodes + i0 + 1};
  const double v[5] = {q.L[2], J * (1 - fx) * (1 - fy), J * fx * (1 - fy), J * (1 - fx) * fy,
                       J * fx * fy};
  std::copy(at, at + 5, idx);
  std::copy(v, v + 5, row);
  return true;
}

void accumulate(const std::vector<SymPixel>& px, double psi, Normal* out) {
  out->A.setZero(kUnknowns, kUnknowns);
  out->b.setZero(kUnknowns);
  out->c = 0;
  const double c = std::cos(psi), s = std::sin(psi);
  for (const SymPixel& q : px) {
    int idx[5];
    double row[5];
    if (!row_of(q, c, s, idx, row)) continue;
    const double w = q.w * q.robust;
    for (int a = 0; a < 5; ++a) {
      const double wa = w * row[a];
      out->b[idx[a]] += wa * q.z;
      for (int b = 0; b < 5; ++b) out->A(idx[a], idx[b]) += wa * row[b];
    }
    out->c += w * q.z * q.z;
  }
}

// The smoothness prior: second differences along each axis of the table.
Eigen::MatrixXd smoothness() {
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(kUnknowns, kUnknowns);
  const auto add = [&](int a, int b, int c) {
    const int id[3] = {a, b, c};
    const double w[3] = {1, -2, 1};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) R(1 + id[i], 1 + id[j]) += w[i] * w[j];
  };
  for (int j = 0; j < kNodes; ++j)
    for (int i = 1; i + 1 < kNodes; ++i) {
      add(j * kNodes + i - 1, j * kNodes + i, j * kNodes + i + 1);
      add((i - 1) * kNodes + j, i * kNodes + j, (i + 1) * kNodes + j);
    }
  return R;
}

// The least-squares solution of the normal equations with the prior (lambda R), and its cost.
Eigen::VectorXd solve(const Normal& n, const Eigen::MatrixXd& R, double lambda) {
  Eigen::MatrixXd A = n.A + lambda * R;
  for (int k = 0; k < kUnknowns; ++k) A(k, k) += 1e-12 * (1 + A(k, k));
  return A.ldlt().solve(n.b);
}
double cost_of(const Normal& n, const Eigen::MatrixXd& R, double lambda) {
  return n.c - n.b.dot(solve(n, R, lambda));
}

// Each pixel's Huber weight at psi under the solution t: 1 within kHuberScale robust sigmas (the
// weighted residuals' MAD) of the free lobe, that scale over the residual beyond. At 1.5 the
// jackknife's sigma stays honest (err/sigma RMS 1.0 over 20 GGX shoots, against 0.9 unweighted and
// 1.5 at 0.6) and is 20 % smaller.
constexpr double kHuberScale = 1.5;
void robust_weights(std::vector<std::vector<SymPixel>>* views, double psi,
                    const Eigen::VectorXd& t) {
  const double c = std::cos(psi), s = std::sin(psi);
  std::vector<double> r;
  for (const auto& px : *views)
    for (const SymPixel& q : px) {
      int idx[5];
      double row[5], pred = 0;
      if (row_of(q, c, s, idx, row))
        for (int a = 0; a < 5; ++a) pred += row[a] * t[idx[a]];
      r.push_back(std::abs(q.z - pred) * std::sqrt(q.w));
    }
  std::vector<double> sorted = r;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double scale = kHuberScale * 1.4826 * sorted[sorted.size() / 2];
  size_t k = 0;
  for (auto& px : *views)
    for (SymPixel& q : px) {
      const double e = r[k++];
      q.robust = e > scale ? scale / e : 1.0;
    }
}

// The minimum of a sampled curve: a parabola through the lowest sample and its neighbours.
double parabola_min(const std::vector<double>& x, const std::vector<double>& y, bool* at_edge) {
  const size_t k = static_cast<size_t>(std::min_element(y.begin(), y.end()) - y.begin());
  if (k == 0 || k + 1 == y.size()) {
    *at_edge = true;
    return x[k];
  }
  const double d = y[k - 1] - 2 * y[k] + y[k + 1];
  const double h = x[k + 1] - x[k];
  return d > 0 ? x[k] + 0.5 * h * (y[k - 1] - y[k + 1]) / d : x[k];
}

}  // namespace

PsiFromSymmetry psi_from_symmetry(const CaptureSet& set, double start_psi_deg, int threads) {
  const auto t0 = SteadyClock::now();
  PsiFromSymmetry out;
  out.start_psi_deg = start_psi_deg;
  std::vector<std::vector<SymPixel>> views;
  {
    GeometryCache cache;
    for (size_t i = 0; i < set.views.size(); ++i) {
      std::vector<SymPixel> px = view_pixels(set, i, &cache);
      if (px.empty()) continue;
      out.pixels += px.size();
      views.push_back(std::move(px));
    }
  }
  out.views = views.size();
  if (views.size() < 2) {
    out.skipped = "fewer than two views lit by one light";
    return out;
  }
  const Eigen::MatrixXd R = smoothness();
  std::vector<Normal> per(views.size());
  tbb::task_arena arena(std::max(1, threads));
  const auto at = [&](double psi_deg, Normal* whole) {
    arena.execute([&] {
      tbb::parallel_for(size_t(0), views.size(),
                        [&](size_t v) { accumulate(views[v], deg_to_rad(psi_deg), &per[v]); });
    });
    *whole = per[0];
    for (size_t v = 1; v < per.size(); ++v) {
      whole->A += per[v].A;
      whole->b += per[v].b;
      whole->c += per[v].c;
    }
  };
  Normal whole;
  at(start_psi_deg, &whole);
  double diag = 0;
  for (int k = 1; k < kUnknowns; ++k) diag += whole.A(k, k);
  const double lambda = kSmoothness * diag / (kUnknowns - 1);
  // Coarse: every 2 degrees over +-45 (the valley is wider than that).
  std::vector<double> xs, ys;
  for (int d = -45; d <= 45; d += 2) {
    at(start_psi_deg + d, &whole);
    xs.push_back(start_psi_deg + d);
    ys.push_back(cost_of(whole, R, lambda));
  }
  bool edge = false;
  const double coarse = parabola_min(xs, ys, &edge);
  // Huber's weights from the residuals at the coarse minimum, held from there on (the jackknife's
  // replicates too): the pixels the free lobe draws worst pull psi less.
  at(coarse, &whole);
  robust_weights(&views, deg_to_rad(coarse), solve(whole, R, lambda));
  // Fine: every 0.1 degree over +-3 about it, the whole and each view left out.
  const size_t V = views.size();
  std::vector<double> fx;
  std::vector<std::vector<double>> fy(V + 1);
  for (int k = -30; k <= 30; ++k) {
    const double p = coarse + 0.1 * k;
    at(p, &whole);
    fx.push_back(p);
    fy[V].push_back(cost_of(whole, R, lambda));
    for (size_t v = 0; v < V; ++v) {
      Normal loo = whole;
      loo.A -= per[v].A;
      loo.b -= per[v].b;
      loo.c -= per[v].c;
      fy[v].push_back(cost_of(loo, R, lambda));
    }
  }
  bool whole_edge = false;
  const double psi = parabola_min(fx, fy[V], &whole_edge);
  double mean = 0;
  for (size_t v = 0; v < V; ++v) {
    bool e = false;
    out.jackknife_psi_deg.push_back(parabola_min(fx, fy[v], &e));
    out.replicate_at_edge = out.replicate_at_edge || e;
    mean += out.jackknife_psi_deg.back();
  }
  mean /= static_cast<double>(V);
  double ss = 0;
  for (double p : out.jackknife_psi_deg) ss += (p - mean) * (p - mean);
  out.sigma_deg = std::sqrt(ss * static_cast<double>(V - 1) / static_cast<double>(V));
  at(psi, &whole);
  double zw = 0, w = 0;
  for (const auto& px : views)
    for (const SymPixel& q : px) zw += q.w * q.robust * q.z, w += q.w * q.robust;
  const double var = whole.c - zw * zw / w;
  out.relative_rms = std::sqrt(std::max(0.0, cost_of(whole, R, lambda)) / std::max(var, 1e-300));
  out.psi_deg = wrap_fiber_deg(psi);
  out.seconds = seconds_since(t0);
  return out;
}

}  // namespace aniso::fitting
