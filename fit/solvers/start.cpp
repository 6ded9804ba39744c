#include "fit/solvers/start.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include "core/angles.h"
#include "core/cpu.h"
#include "core/progress.h"
#include "fit/solvers/line_pixel_lanes.h"
#include "models/params.h"
#include "models/safe_math.h"

namespace aniso::fitting {

void set_start_kd_ks(const double kd[3], const double ks[3], Core* c) {
  // Inside the bounds: where a node's specular column is all but zero (x^n ~1e-14 on every pixel),
  // any k_s fits as well and the closed form can give 1e22; a solver started there, past the bound,
  // stops where it started (docs/solver-rules.md "The start's k_d, k_s are clamped").
  static const double kd_hi = line_param("kd").hi, ks_hi = line_param("ks").hi;
  for (int ch = 0; ch < 3; ++ch) {
    c->kd[ch] = std::clamp(kd[ch], 1e-4, kd_hi);
    c->ks[ch] = std::clamp(ks[ch], 1e-4, ks_hi);
  }
}

double line_node_cost(const ObsSet& os, const std::vector<size_t>& subset, double psi, int log2n,
                      double kd[3], double ks[3]) {
  const double c = std::cos(psi), s = std::sin(psi);
  return solve_kd_ks(
      os, subset,
      [&](size_t, const Observation& o, double* dcol, double* scol) {
        const double b = clamp_unit(c * o.V.u + s * o.V.w), sV = sin_from_cos(b);
        for (uint32_t k = 0; k < o.num_lights; ++k) {
          const ObsLight& l = os.lights[o.first_light + k];
          const double a = clamp_unit(c * l.L.u + s * l.L.w), sL = sin_from_cos(a);
          double p = std::max(sL * sV - a * b, 0.0);  // x^n by squaring: no exp, no log
          for (int i = 0; i < log2n; ++i) p *= p;
          for (int ch = 0; ch < 3; ++ch) {
            dcol[ch] += l.E[ch] * l.L.n * sL;
            scol[ch] += l.E[ch] * l.L.n * p;
          }
        }
      },
      kd, ks);
}

void line_nodes_cost(const ObsSet& os, const std::vector<size_t>& subset, const double* psi,
                     int count, int log2n, NodeFit* out) {
  int i = 0;
  if (line_lanes_on(os))
    for (; i + 4 <= count; i += 4) {
      KdKsSums sums[4];
      line_nodes_simd(os, subset.data(), subset.size(), psi + i, log2n, sums);
      for (int k = 0; k < 4; ++k) out[i + k].cost = sums[k].solve(out[i + k].kd, out[i + k].ks);
    }
  for (; i < count; ++i)
    out[i].cost = line_node_cost(os, subset, psi[i], log2n, out[i].kd, out[i].ks);
}

namespace {

typedef double v8d __attribute__((vector_size(64)));
typedef long v8l __attribute__((vector_size(64)));
#define ANISO_KDKS8 ANISO_AVX512F __attribute__((optimize("fp-contract=off")))

// The sum of squares at (a, b): KdKsSums::solve's sse, term by term.
ANISO_KDKS8 __attribute__((always_inline)) inline v8d sse8(v8d a, v8d b, v8d dd, v8d ds, v8d ss,
                                                           v8d dy, v8d sy, v8d yy) {
  return yy - 2 * a * dy - 2 * b * sy + a * a * dd + 2 * a * b * ds + b * b * ss;
}
ANISO_KDKS8 __attribute__((always_inline)) inline v8d pick8(v8l m, v8d a, v8d b) {
  return m ? a : b;
}

// KdKsSums::solve's steps for eight nodes of one channel, a lane each: the same operations in the
// same order (no fused multiply-add: the attribute's fp-contract=off), the candidates' choices as
// masks.
ANISO_KDKS8 void solve8_channel(const double (&f)[6][8], double* ba_out, double* bb_out,
                                double* bc_out) {
  v8d dd, ds, ss, dy, sy, yy;
  std::memcpy(&dd, f[0], 64), std::memcpy(&ds, f[1], 64), std::memcpy(&ss, f[2], 64);
  std::memcpy(&dy, f[3], 64), std::memcpy(&sy, f[4], 64), std::memcpy(&yy, f[5], 64);
  const v8d zero = {0, 0, 0, 0, 0, 0, 0, 0};
  v8d ba = zero, bb = zero, bc = sse8(zero, zero, dd, ds, ss, dy, sy, yy);
  const v8d det = dd * ss - ds * ds;
  {
    const v8d a = (dy * ss - sy * ds) / det, b = (sy * dd - dy * ds) / det;
    const v8d c = sse8(a, b, dd, ds, ss, dy, sy, yy);
    const v8l take = (det > 1e-300) & (a >= 0.0) & (b >= 0.0) & (c < bc);
    ba = pick8(take, a, ba), bb = pick8(take, b, bb), bc = pick8(take, c, bc);
  }
  {
    const v8d q = dy / dd, a = pick8(q < 0.0, zero, q);
    const v8d c = sse8(a, zero, dd, ds, ss, dy, sy, yy);
    const v8l take = (dd > 0.0) & (c < bc);
    ba = pick8(take, a, ba), bb = pick8(take, zero, bb), bc = pick8(take, c, bc);
  }
  {
    const v8d q = sy / ss, b = pick8(q < 0.0, zero, q);
    const v8d c = sse8(zero, b, dd, ds, ss, dy, sy, yy);
    const v8l take = (ss > 0.0) & (c < bc);
    ba = pick8(take, zero, ba), bb = pick8(take, b, bb), bc = pick8(take, c, bc);
  }
  std::memcpy(ba_out, &ba, 64), std::memcpy(bb_out, &bb, 64), std::memcpy(bc_out, &bc, 64);
}

}  // namespace

void solve_kd_ks8(const KdKsSums sums[8], NodeFit out[8]) {
  if (!cpu_has_avx512f()) {
    for (int k = 0; k < 8; ++k) out[k].cost = sums[k].solve(out[k].kd, out[k].ks);
    return;
  }
  double cost[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (int ch = 0; ch < 3; ++ch) {
    double f[6][8], ba[8], bb[8], bc[8];
    for (int k = 0; k < 8; ++k) {
      const KdKsSums& s = sums[k];
      f[0][k] = s.dd[ch], f[1][k] = s.ds[ch], f[2][k] = s.ss[ch];
      f[3][k] = s.dy[ch], f[4][k] = s.sy[ch], f[5][k] = s.yy[ch];
    }
    solve8_channel(f, ba, bb, bc);
    for (int k = 0; k < 8; ++k) out[k].kd[ch] = ba[k], out[k].ks[ch] = bb[k], cost[k] += bc[k];
  }
  for (int k = 0; k < 8; ++k) out[k].cost = cost[k];
}

double KdKsSums::solve(double kd[3], double ks[3]) const {
  double cost = 0;
  for (int ch = 0; ch < 3; ++ch) {
    auto sse = [&](double a, double b) {
      return yy[ch] - 2 * a * dy[ch] - 2 * b * sy[ch] + a * a * dd[ch] + 2 * a * b * ds[ch] +
             b * b * ss[ch];
    };
    double ba = 0, bb = 0, bc = sse(0, 0);
    const double det = dd[ch] * ss[ch] - ds[ch] * ds[ch];
    if (det > 1e-300) {
      const double a = (dy[ch] * ss[ch] - sy[ch] * ds[ch]) / det,
                   b = (sy[ch] * dd[ch] - dy[ch] * ds[ch]) / det;
      if (a >= 0 && b >= 0 && sse(a, b) < bc) ba = a, bb = b, bc = sse(a, b);
    }
    if (dd[ch] > 0) {
      const double a = std::max(dy[ch] / dd[ch], 0.0);
      if (sse(a, 0) < bc) ba = a, bb = 0, bc = sse(a, 0);
    }
    if (ss[ch] > 0) {
      const double b = std::max(sy[ch] / ss[ch], 0.0);
      if (sse(0, b) < bc) ba = 0, bb = b, bc = sse(0, b);
    }
    kd[ch] = ba;
    ks[ch] = bb;
    cost += bc;
  }
  return cost;
}

namespace {

constexpr int kGridPsi = 36, kGridN = kLineGridN;  // psi in 5 degree steps; n = 2^1 .. 2^12

// Every n of the grid at one psi in one pass: the lobe x^n for n = 2, 4, ..., 4096 by repeated
// squaring of x = sin_L sin_V - cos_L cos_V (each node's value is exactly pos_pow(x, n) up to
// rounding), the sums of each node's k_d, k_s problem. The diffuse column does not depend on n:
// its sums are made once; the specular ones in flat arrays over (n, channel), one loop each.
void grid_column(const ObsSet& os, double psi, KdKsSums sums[kGridN]) {
  constexpr int kCols = kGridN * 3;
  const double c = std::cos(psi), s = std::sin(psi);
  double dd[3] = {}, dy[3] = {}, yy[3] = {}, ds[kCols] = {}, ss[kCols] = {}, sy[kCols] = {};
  for (const Observation& o : os.obs) {
    const double b = clamp_unit(c * o.V.u + s * o.V.w), sV = sin_from_cos(b);
    double dcol[3] = {0, 0, 0}, scol[kCols] = {};
    for (uint32_t k = 0; k < o.num_lights; ++k) {
      const ObsLight& l = os.lights[o.first_light + k];
      const double a = clamp_unit(c * l.L.u + s * l.L.w), sL = sin_from_cos(a);
      double w[3];
      for (int ch = 0; ch < 3; ++ch) w[ch] = l.E[ch] * l.L.n, dcol[ch] += w[ch] * sL;
      double p = std::max(sL * sV - a * b, 0.0);
      for (int in = 0; in < kGridN; ++in) {
        p *= p;
        for (int ch = 0; ch < 3; ++ch) scol[3 * in + ch] += w[ch] * p;
      }
    }
    const double y[3] = {o.y[0], o.y[1], o.y[2]};
    for (int ch = 0; ch < 3; ++ch) {
      dd[ch] += dcol[ch] * dcol[ch];
      dy[ch] += dcol[ch] * y[ch];
      yy[ch] += y[ch] * y[ch];
    }
    for (int in = 0; in < kGridN; ++in)
      for (int ch = 0; ch < 3; ++ch) {
        const double v = scol[3 * in + ch];
        ds[3 * in + ch] += dcol[ch] * v;
        ss[3 * in + ch] += v * v;
        sy[3 * in + ch] += v * y[ch];
      }
  }
  for (int in = 0; in < kGridN; ++in)
    for (int ch = 0; ch < 3; ++ch) {
      KdKsSums& t = sums[in];
      t.dd[ch] = dd[ch], t.dy[ch] = dy[ch], t.yy[ch] = yy[ch];
      t.ds[ch] = ds[3 * in + ch], t.ss[ch] = ss[3 * in + ch], t.sy[ch] = sy[3 * in + ch];
    }
}

// The subset's observations and lights side by side in their own arrays: the grid reads them 36
// times, and scattered over the whole set they were most of its time (cache misses).
ObsSet compact(const ObsSet& os, const std::vector<size_t>& subset) {
  ObsSet out;
  out.simd = os.simd;
  out.obs.reserve(subset.size());
  for (size_t i : subset) {
    Observation o = os.obs[i];
    o.first_light = static_cast<uint32_t>(out.lights.size());
    out.lights.insert(out.lights.end(), os.lights.begin() + os.obs[i].first_light,
                      os.lights.begin() + os.obs[i].first_light + o.num_lights);
    out.obs.push_back(o);
  }
  return out;
}

}  // namespace

std::string line_grid_start(const ObsSet& os, Core* st, const ProgressSink* progress,
                            std::optional<Core>* other) {
  Progress bar("fit: start grid (psi x n)", kGridPsi, progress);
  const std::vector<size_t> subset = start_subset(os.obs.size(), kMaxStartObs);
  const ObsSet some = compact(os, subset);
  std::vector<KdKsSums> sums(kGridPsi * kGridN);
  // Four columns at a time where the CPU has AVX2 and FMA (the same sums up to FMA's rounding).
  const bool simd = line_lanes_on(os);
  tbb::parallel_for(0, simd ? kGridPsi / 4 : kGridPsi, [&](int task) {
    if (simd) {
      const double psi[4] = {4 * task * M_PI / kGridPsi, (4 * task + 1) * M_PI / kGridPsi,
                             (4 * task + 2) * M_PI / kGridPsi, (4 * task + 3) * M_PI / kGridPsi};
      KdKsSums out[4][kGridN];
      line_grid_simd(some, psi, out);
      for (int i = 0; i < 4; ++i) {
        std::copy(out[i], out[i] + kGridN, &sums[(4 * task + i) * kGridN]);
        bar.advance();
      }
    } else {
      grid_column(some, task * M_PI / kGridPsi, &sums[task * kGridN]);
      bar.advance();
    }
  });
  // Each psi's best node over n: the grid's costs as a function of psi (a half turn, cyclic).
  struct Node {
    double cost = std::numeric_limits<double>::infinity();
    int in = 0;
    double kd[3] = {0, 0, 0}, ks[3] = {0, 0, 0};
  };
  std::vector<Node> col(kGridPsi);
  int ib = 0;
  for (int ip = 0; ip < kGridPsi; ++ip) {
    for (int in = 0; in < kGridN; ++in) {
      double kd[3], ks[3];
      const double cost = sums[ip * kGridN + in].solve(kd, ks);
      if (cost < col[ip].cost) {
        col[ip].cost = cost, col[ip].in = in;
        std::copy(kd, kd + 3, col[ip].kd);
        std::copy(ks, ks + 3, col[ip].ks);
      }
    }
    if (col[ip].cost < col[ib].cost) ib = ip;
  }
  auto to_core = [&](int ip, Core* c) {
    c->psi = ip * M_PI / kGridPsi;
    c->logn = (col[ip].in + 1) * std::log(2.0);
    set_start_kd_ks(col[ip].kd, col[ip].ks, c);
  };
  to_core(ib, st);
  if (other) {  // the lowest valley floor 3 columns (15 degrees) or more from the best
    other->reset();
    int io = -1;
    for (int ip = 0; ip < kGridPsi; ++ip) {
      const int d = std::abs(ip - ib), away = std::min(d, kGridPsi - d);
      const double prev = col[(ip + kGridPsi - 1) % kGridPsi].cost;
      const double next = col[(ip + 1) % kGridPsi].cost;
      if (away >= 3 && col[ip].cost <= prev && col[ip].cost <= next &&
          (io < 0 || col[ip].cost < col[io].cost))
        io = ip;
    }
    if (io >= 0) {
      Core c = *st;
      to_core(io, &c);
      *other = c;
    }
  }
  char buf[160];
  std::snprintf(buf, sizeof buf, "grid psi=%.1f deg, n=%.0f (36 x 12 nodes on %zu pixels)",
                rad_to_deg(st->psi), std::exp(st->logn), subset.size());
  return buf;
}

}  // namespace aniso::fitting
