#include "fit/solvers/line_pixel_lanes.h"

#include <atomic>
#include <cmath>
#include <cstring>

#include "core/cpu.h"
#include "fit/solvers/start.h"
#include "fit/solvers/texel_lanes.h"

namespace aniso::fitting {

namespace {

// GCC's vector types: four doubles (one AVX2 register) and four 64-bit integers; a cast between
// the two reinterprets the bits. Everything that touches them is compiled for AVX2 and FMA only.
typedef double v4d __attribute__((vector_size(32)));
typedef long long v4i __attribute__((vector_size(32)));

ANISO_AVX2_FMA_INLINE v4d splat(double x) { return v4d{x, x, x, x}; }
ANISO_AVX2_FMA_INLINE v4d select(v4i m, v4d a, v4d b) { return m ? a : b; }
ANISO_AVX2_FMA_INLINE v4d vmax(v4d a, v4d b) { return select(a > b, a, b); }
ANISO_AVX2_FMA_INLINE v4d vmin(v4d a, v4d b) { return select(a < b, a, b); }
ANISO_AVX2_FMA_INLINE v4d vsqrt(v4d a) { return __builtin_ia32_sqrtpd256(a); }

// exp and log of the lanes (core/simd_exp_log.inc, shared with the fiber lobe's nodes).
typedef v4d vd;
typedef v4i vl;
#define SIMD_INLINE ANISO_AVX2_FMA_INLINE
#include "core/simd_exp_log.inc"
#undef SIMD_INLINE

// sqrt(1 - a^2) and its derivative, as sin_and_derivative (fit/solvers/line_pixel.h) lane by lane.
ANISO_AVX2_FMA_INLINE void vsin(v4d a, v4d* s, v4d* ds) {
  const v4d x = splat(1.0) - a * a;
  const double chord = 1 / std::sqrt(kSqrtChordEps);
  const v4d root = vsqrt(vmax(x, splat(kSqrtChordEps)));
  const v4i zero = x <= splat(0.0), near = x < splat(kSqrtChordEps);
  *s = select(zero, splat(0.0), select(near, x * splat(chord), root));
  *ds = select(zero, splat(0.0), select(near, splat(-2.0 * chord) * a, -a / root));
}

ANISO_AVX2_FMA_INLINE double hsum(v4d v) { return (v[0] + v[1]) + (v[2] + v[3]); }

// Per-lane sums of a chunk (the layout of ChannelSums<8>, four lanes each).
struct LaneSums {
  v4d h[3][10], g[3][4], cost, rss;
};

// Per-lane HuberCurvature of a chunk.
struct LaneCurvature {
  v4d c[36];
};

ANISO_AVX2_FMA_INLINE bool any(v4i m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }

// The four observations' values, lane by lane.
struct Lanes {
  v4d Vu, Vw, Lu, Lw, Ln, E[3], y[3], mask;
};

ANISO_AVX2_FMA_INLINE v4d load4(const double* p) {
  v4d v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// Each lane vector built from its four values in registers (scalar stores to a table read back
// as 32-byte loads stall: a load cannot take its bytes from several stores in flight).
ANISO_AVX2_FMA_INLINE void gather(const ObsSet& os, const size_t* idx, size_t count, Lanes* q) {
  const Observation* o[4];
  const ObsLight* l[4];
  for (int i = 0; i < 4; ++i) {
    o[i] = &os.obs[idx[static_cast<size_t>(i) < count ? i : 0]];
    l[i] = &os.lights[o[i]->first_light];
  }
#define ANISO_LANES(field) v4d{o[0]->field, o[1]->field, o[2]->field, o[3]->field}
#define ANISO_LIGHT_LANES(field) \
  v4d { l[0]->field, l[1]->field, l[2]->field, l[3]->field }
  q->Vu = ANISO_LANES(V.u), q->Vw = ANISO_LANES(V.w);
  q->Lu = ANISO_LIGHT_LANES(L.u), q->Lw = ANISO_LIGHT_LANES(L.w), q->Ln = ANISO_LIGHT_LANES(L.n);
  for (int k = 0; k < 3; ++k) q->E[k] = ANISO_LIGHT_LANES(E[k]), q->y[k] = ANISO_LANES(y[k]);
#undef ANISO_LANES
#undef ANISO_LIGHT_LANES
  q->mask = v4d{1.0, count > 1 ? 1.0 : 0.0, count > 2 ? 1.0 : 0.0, count > 3 ? 1.0 : 0.0};
}

#define LE_INLINE ANISO_AVX2_FMA_INLINE
#include "fit/solvers/line_equation.inc"
#undef LE_INLINE

// fit/solvers/line_equation.inc's primitives in four double lanes.
struct LaneOps {
  ANISO_AVX2_FMA_INLINE static v4d clamp_unit(v4d a) {
    return vmin(vmax(a, splat(-1.0)), splat(1.0));
  }
  ANISO_AVX2_FMA_INLINE static void sin(v4d a, v4d* s, v4d* ds) { vsin(a, s, ds); }
  ANISO_AVX2_FMA_INLINE static v4d exp(v4d t) { return vexp(t); }
  ANISO_AVX2_FMA_INLINE static v4d lit(v4d x, v4d a, v4d b) { return select(x > splat(0.0), a, b); }
};

ANISO_AVX2_FMA void group(const Lanes& q, const LinePixelParams& p, const RobustLoss& loss,
                          bool jac, LaneCurvature* curv, LaneSums* acc) {
  const v4d c = splat(p.c), sn = splat(p.sn), n = splat(p.n);
  const v4d one = splat(1.0);
  const LineView<v4d> view = line_view<LaneOps>(c, sn, q.Vu, q.Vw);
  const LineLight<v4d> g = line_light<LaneOps>(c, sn, q.Lu, q.Lw, view);
  const v4d xs = LaneOps::lit(g.x, g.x, one);
  const LineLobe<v4d> lobe = line_lobe<LaneOps>(n, g.x, xs, vlog(xs));
  v4d r[3], v[3][4];
  for (int k = 0; k < 3; ++k) {
    const v4d w = q.E[k] * q.Ln, kd = splat(p.kd[k]), ks = splat(p.ks[k]);
    r[k] = w * (kd * g.sL + ks * lobe.S) - q.y[k];
    v[k][0] = w * g.sL;
    v[k][1] = w * lobe.S;
    v[k][2] = w * ks * lobe.dS_dlogn;
    v[k][3] = w * (kd * g.dD_dpsi + ks * lobe.dS_dx * g.dx_dpsi);
  }
  const v4d r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  v4d rho = r2, wt = one;
  v4i far{};
  if (loss.kind == FitLoss::kHuber) {
    const v4d A = splat(loss.a), out = vsqrt(vmax(r2, splat(1e-300)));
    far = r2 > A * A;
    rho = select(far, splat(2 * loss.a) * out - A * A, r2);
    wt = select(far, A / out, one);
  }
  wt *= q.mask;
  acc->cost += rho * q.mask;
  acc->rss += wt * r2;
  if (!jac) return;
  for (int k = 0; k < 3; ++k) {
    int t = 0;
    for (int i = 0; i < 4; ++i) {
      const v4d wv = wt * v[k][i];
      acc->g[k][i] += wv * r[k];
      for (int j = i; j < 4; ++j) acc->h[k][t++] += wv * v[k][j];
    }
  }
  if (!curv || !any(far)) return;
  const v4d A = splat(loss.a);
  const v4d coef = select(far, wt / r2 * vmin(vsqrt(r2) / A - splat(1.0), splat(1.0)), splat(0.0));
  v4d u[8];
  for (int k = 0; k < 3; ++k) u[k] = r[k] * v[k][0], u[3 + k] = r[k] * v[k][1];
  for (int j = 0; j < 2; ++j)
    u[6 + j] = r[0] * v[0][2 + j] + r[1] * v[1][2 + j] + r[2] * v[2][2 + j];
  int t = 0;
  for (int i = 0; i < 8; ++i) {
    const v4d cu = coef * u[i];
    for (int j = i; j < 8; ++j) curv->c[t++] += cu * u[j];
  }
}

// The lane sums into the chunk's: lane by lane, a fixed order.
ANISO_AVX2_FMA void add_lanes(const LaneSums& acc, ChannelSums<8>* sums) {
  sums->cost += hsum(acc.cost);
  sums->rss += hsum(acc.rss);
  for (int k = 0; k < 3; ++k) {
    for (int t = 0; t < 10; ++t) sums->h[k][t] += hsum(acc.h[k][t]);
    for (int i = 0; i < 4; ++i) sums->g[k][i] += hsum(acc.g[k][i]);
  }
}

ANISO_AVX2_FMA void pass_avx2(const ObsSet& os, const size_t* idx, size_t count,
                              const LinePixelParams& p, const RobustLoss& loss, bool jac,
                              ChannelSums<8>* sums, HuberCurvature<8>* curv) {
  LaneSums acc;
  std::memset(&acc, 0, sizeof acc);
  Lanes q;
  LaneCurvature lc;
  LaneCurvature* with = jac && curv && loss.kind == FitLoss::kHuber ? &lc : nullptr;
  if (with) std::memset(&lc, 0, sizeof lc);
  for (size_t i = 0; i < count; i += 4) {
    gather(os, idx + i, count - i, &q);
    group(q, p, loss, jac, with, &acc);
  }
  add_lanes(acc, sums);
  if (with)
    for (int t = 0; t < 36; ++t) curv->c[t] += hsum(lc.c[t]);
}

// Four floats of row k of a group of eight, as doubles.
ANISO_AVX2_FMA_INLINE v4d row4(const float* g, int k) {
  return v4d{g[8 * k], g[8 * k + 1], g[8 * k + 2], g[8 * k + 3]};
}

// The texel's transposed rows (fit/solvers/texel_lanes.h) in double, four lanes at a time: the
// weights already times n_L (Ln 1).
ANISO_AVX2_FMA void lanes_pass_avx2(const TexelLanes& t, const LinePixelParams& p, bool jac,
                                    ChannelSums<8>* sums) {
  LaneSums acc;
  std::memset(&acc, 0, sizeof acc);
  const RobustLoss none{FitLoss::kNone, 0};
  Lanes q;
  q.Ln = splat(1.0);
  for (size_t gi = 0; gi < t.groups; ++gi)
    for (int half = 0; half < 2; ++half) {
      const float* g = t.f.data() + gi * TexelLanes::kRows * 8 + 4 * half;
      q.Vu = row4(g, 0), q.Vw = row4(g, 1), q.Lu = row4(g, 2), q.Lw = row4(g, 3);
      for (int k = 0; k < 3; ++k) q.E[k] = row4(g, 5 + k), q.y[k] = row4(g, 8 + k);
      q.mask = row4(g, 11);
      group(q, p, none, jac, nullptr, &acc);
    }
  add_lanes(acc, sums);
}

// Four start nodes at once, psi in the lanes (n = 2^log2n, x^n by squaring): line_node_cost's
// columns and sums (fit/solvers/start.cpp) lane by lane, over observations with any number of
// lights.
ANISO_AVX2_FMA void nodes_avx2(const ObsSet& os, const size_t* idx, size_t count,
                               const double psi[4], int log2n, KdKsSums out[4]) {
  v4d c, sn;
  for (int i = 0; i < 4; ++i) c[i] = std::cos(psi[i]), sn[i] = std::sin(psi[i]);
  const v4d one = splat(1.0), minus = splat(-1.0), zero = splat(0.0);
  v4d dd[3], ds[3], ss[3], dy[3], sy[3];
  double yy[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k) dd[k] = ds[k] = ss[k] = dy[k] = sy[k] = zero;
  for (size_t j = 0; j < count; ++j) {
    const Observation& o = os.obs[idx[j]];
    const v4d b = vmin(vmax(c * o.V.u + sn * o.V.w, minus), one);
    v4d sV, unused;
    vsin(b, &sV, &unused);
    v4d dcol[3] = {zero, zero, zero}, scol[3] = {zero, zero, zero};
    for (uint32_t k = 0; k < o.num_lights; ++k) {
      const ObsLight& l = os.lights[o.first_light + k];
      const v4d a = vmin(vmax(c * l.L.u + sn * l.L.w, minus), one);
      v4d sL;
      vsin(a, &sL, &unused);
      v4d x = vmax(sL * sV - a * b, zero);
      for (int i = 0; i < log2n; ++i) x *= x;
      for (int ch = 0; ch < 3; ++ch) {
        const v4d w = splat(l.E[ch] * l.L.n);
        dcol[ch] += w * sL;
        scol[ch] += w * x;
      }
    }
    for (int ch = 0; ch < 3; ++ch) {
      const double y = o.y[ch];
      dd[ch] += dcol[ch] * dcol[ch];
      ds[ch] += dcol[ch] * scol[ch];
      ss[ch] += scol[ch] * scol[ch];
      dy[ch] += dcol[ch] * splat(y);
      sy[ch] += scol[ch] * splat(y);
      yy[ch] += y * y;
    }
  }
  for (int i = 0; i < 4; ++i)
    for (int ch = 0; ch < 3; ++ch) {
      out[i].dd[ch] = dd[ch][i], out[i].ds[ch] = ds[ch][i], out[i].ss[ch] = ss[ch][i];
      out[i].dy[ch] = dy[ch][i], out[i].sy[ch] = sy[ch][i], out[i].yy[ch] = yy[ch];
    }
}

// Four columns of the start's grid at once, psi in the lanes: for every pixel the lobe x^n for
// n = 2, 4, ..., 2^N by repeated squaring (grid_column in fit/solvers/start.cpp, lane by lane).
template <int N>
ANISO_AVX2_FMA void grid_avx2(const ObsSet& os, const double psi[4], KdKsSums out[4][N]) {
  v4d c, sn;
  for (int i = 0; i < 4; ++i) c[i] = std::cos(psi[i]), sn[i] = std::sin(psi[i]);
  const v4d one = splat(1.0), minus = splat(-1.0), zero = splat(0.0);
  v4d dd[3], dy[3], ds[3 * N], ss[3 * N], sy[3 * N];
  double yy[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k) dd[k] = dy[k] = zero;
  for (int k = 0; k < 3 * N; ++k) ds[k] = ss[k] = sy[k] = zero;
  for (const Observation& o : os.obs) {
    const v4d b = vmin(vmax(c * o.V.u + sn * o.V.w, minus), one);
    v4d sV, unused;
    vsin(b, &sV, &unused);
    v4d dcol[3] = {zero, zero, zero}, scol[3 * N];
    for (int k = 0; k < 3 * N; ++k) scol[k] = zero;
    for (uint32_t k = 0; k < o.num_lights; ++k) {
      const ObsLight& l = os.lights[o.first_light + k];
      const v4d a = vmin(vmax(c * l.L.u + sn * l.L.w, minus), one);
      v4d sL;
      vsin(a, &sL, &unused);
      v4d w[3];
      for (int ch = 0; ch < 3; ++ch) w[ch] = splat(l.E[ch] * l.L.n), dcol[ch] += w[ch] * sL;
      v4d p = vmax(sL * sV - a * b, zero);
      for (int in = 0; in < N; ++in) {
        p *= p;
        for (int ch = 0; ch < 3; ++ch) scol[3 * in + ch] += w[ch] * p;
      }
    }
    v4d y[3];
    for (int ch = 0; ch < 3; ++ch) {
      const double yc = o.y[ch];
      y[ch] = splat(yc);
      dd[ch] += dcol[ch] * dcol[ch];
      dy[ch] += dcol[ch] * y[ch];
      yy[ch] += yc * yc;
    }
    for (int in = 0; in < N; ++in)
      for (int ch = 0; ch < 3; ++ch) {
        const v4d v = scol[3 * in + ch];
        ds[3 * in + ch] += dcol[ch] * v;
        ss[3 * in + ch] += v * v;
        sy[3 * in + ch] += v * y[ch];
      }
  }
  for (int i = 0; i < 4; ++i)
    for (int in = 0; in < N; ++in)
      for (int ch = 0; ch < 3; ++ch) {
        KdKsSums& t = out[i][in];
        t.dd[ch] = dd[ch][i], t.dy[ch] = dy[ch][i], t.yy[ch] = yy[ch];
        t.ds[ch] = ds[3 * in + ch][i], t.ss[ch] = ss[3 * in + ch][i], t.sy[ch] = sy[3 * in + ch][i];
      }
}

ANISO_AVX2_FMA void exp_log_avx2(const double in[4], double exp_out[4], double log_out[4]) {
  v4d x;
  std::memcpy(&x, in, sizeof x);
  const v4d e = vexp(x), l = vlog(x);
  std::memcpy(exp_out, &e, sizeof e);
  std::memcpy(log_out, &l, sizeof l);
}

}  // namespace

void line_pass_simd(const ObsSet& os, const size_t* idx, size_t count, const LinePixelParams& p,
                    const RobustLoss& loss, bool jac, ChannelSums<8>* sums,
                    HuberCurvature<8>* curv) {
  pass_avx2(os, idx, count, p, loss, jac, sums, curv);
}

void line_pass_lanes(const TexelLanes& t, const LinePixelParams& p, bool jac,
                     ChannelSums<8>* sums) {
  lanes_pass_avx2(t, p, jac, sums);
}

void line_nodes_simd(const ObsSet& os, const size_t* idx, size_t count, const double psi[4],
                     int log2n, KdKsSums out[4]) {
  nodes_avx2(os, idx, count, psi, log2n, out);
}

void line_grid_simd(const ObsSet& os, const double psi[4], KdKsSums out[4][kLineGridN]) {
  grid_avx2<kLineGridN>(os, psi, out);
}

void simd_exp_log(const double in[4], double exp_out[4], double log_out[4]) {
  exp_log_avx2(in, exp_out, log_out);
}

}  // namespace aniso::fitting
