#include "fit/texel_simd.h"

#include <immintrin.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "fit/line_simd.h"
#include "fit/start.h"

namespace aniso::fitting {

namespace {

// GCC's vector types: eight floats (one AVX2 register) and eight 32-bit integers.
typedef float v8f __attribute__((vector_size(32)));
typedef int v8i __attribute__((vector_size(32)));
#define ANISO_AVX2 __attribute__((target("avx2,fma")))
#define ANISO_AVX2_INLINE __attribute__((target("avx2,fma"), always_inline)) inline

ANISO_AVX2_INLINE v8f splat(float x) { return v8f{x, x, x, x, x, x, x, x}; }
ANISO_AVX2_INLINE v8f select(v8i m, v8f a, v8f b) { return m ? a : b; }
ANISO_AVX2_INLINE v8f vmax(v8f a, v8f b) { return select(a > b, a, b); }
ANISO_AVX2_INLINE v8f vmin(v8f a, v8f b) { return select(a < b, a, b); }
ANISO_AVX2_INLINE v8f vsqrt(v8f a) { return __builtin_ia32_sqrtps256(a); }
ANISO_AVX2_INLINE v8f clamp_unit(v8f a) { return vmin(vmax(a, splat(-1.f)), splat(1.f)); }

// exp(t): t = k ln 2 + r, |r| <= ln 2 / 2, e^r by its Taylor series to r^7 (truncation below
// 2e-8 relative), times 2^k built in the exponent bits; 0 below -87 (subnormal 2^k).
ANISO_AVX2_INLINE v8f vexp(v8f t) {
  const v8f magic = splat(12582912.f);  // 1.5 * 2^23: adding it rounds to an integer
  const v8f tc = vmin(vmax(t, splat(-87.f)), splat(88.f));
  const v8f kf = (tc * splat(1.44269504f) + magic) - magic;
  const v8f r = (tc - kf * splat(0.693145751953125f)) - kf * splat(1.428606765330187e-06f);
  v8f p = splat(1.f / 5040);
  for (const float c : {1.f / 720, 1.f / 120, 1.f / 24, 1.f / 6, 0.5f, 1.f, 1.f}) p = p * r + c;
  const v8i k = (v8i)(kf + magic) - (v8i)magic;
  return select(t < splat(-87.f), splat(0.f), p * (v8f)((k + 127) << 23));
}

// log(x), x > 0 (subnormals taken as the smallest normal): x = m 2^e, m in [sqrt(1/2), sqrt(2)),
// log m = 2 atanh(s), s = (m - 1) / (m + 1), |s| <= 0.1716, by its series to s^9.
ANISO_AVX2_INLINE v8f vlog(v8f x) {
  x = vmax(x, splat(1.17549435e-38f));
  const v8i bits = (v8i)x;
  const v8i e0 = ((bits >> 23) & 0xff) - 127;
  v8f m = (v8f)((bits & 0x007fffff) | 0x3f800000);
  const v8i big = m > splat(1.41421356f);
  m = select(big, m * splat(0.5f), m);
  const v8f ed = __builtin_convertvector(e0 - big, v8f);  // big is -1 where m was halved
  const v8f f = m - splat(1.f);
  const v8f s = f / (splat(2.f) + f), z = s * s, hfsq = splat(0.5f) * f * f;
  const v8f R = z * (splat(2.f / 3) + z * (splat(2.f / 5) + z * (splat(2.f / 7) + z * (2.f / 9))));
  return ed * splat(0.693145751953125f) -
         ((hfsq - (s * (hfsq + R) + ed * splat(1.428606765330187e-06f))) - f);
}

// sqrt(1 - a^2) and its derivative, as sin_and_derivative (fit/line_pixel.h); 1 - a^2 as
// (1 - a)(1 + a), which float keeps near |a| = 1.
ANISO_AVX2_INLINE void vsin(v8f a, v8f* s, v8f* ds) {
  const v8f x = (splat(1.f) - a) * (splat(1.f) + a);
  const float eps = static_cast<float>(kSqrtChordEps);
  const float chord = static_cast<float>(1 / std::sqrt(kSqrtChordEps));
  const v8f root = vsqrt(vmax(x, splat(eps)));
  const v8i zero = x <= splat(0.f), near = x < splat(eps);
  *s = select(zero, splat(0.f), select(near, x * splat(chord), root));
  *ds = select(zero, splat(0.f), select(near, splat(-2.f * chord) * a, -a / root));
}

// The eight lanes' sum in double: the halves widened and added, then pairwise (eight additions
// in a row were a chain of 32 cycles, ~100 of them a pass).
ANISO_AVX2_INLINE double hsum(v8f v) {
  const __m256d a = _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(__m256(v))),
                                  _mm256_cvtps_pd(_mm256_extractf128_ps(__m256(v), 1)));
  const __m128d b = _mm_add_pd(_mm256_castpd256_pd128(a), _mm256_extractf128_pd(a, 1));
  return _mm_cvtsd_f64(_mm_add_sd(b, _mm_unpackhi_pd(b, b)));
}

// One group of the lanes: rows in TexelLanes' order.
struct Group {  // rows 0-10 (the mask row is the double lanes'; here padding has W = y = 0)
  v8f Vu, Vw, Lu, Lw, Ln, W[3], y[3];
};
ANISO_AVX2_INLINE v8f load8(const float* p) {
  v8f v;
  std::memcpy(&v, p, sizeof v);  // one unaligned 32-byte load
  return v;
}
// Row by row straight into registers (a table of pointers to the members made the compiler copy
// through the stack in 16-byte halves and stall reading them back whole).
ANISO_AVX2_INLINE Group load_group(const float* g) {
  Group q;
  q.Vu = load8(g), q.Vw = load8(g + 8), q.Lu = load8(g + 16), q.Lw = load8(g + 24);
  q.Ln = load8(g + 32);
  for (int k = 0; k < 3; ++k) q.W[k] = load8(g + 8 * (5 + k)), q.y[k] = load8(g + 8 * (8 + k));
  return q;
}

struct LaneSums {
  v8f h[3][10], g[3][4], cost;
  v8f grey_h[15], grey_g[3][5];  // under grey lights (grey_jac_sums)
};

// What a group's lanes share across the three channels, and their residuals, kept for the
// per-channel sums that follow.
struct GroupTerms {
  v8f sL, S, dS_dlogn, dD_dpsi, dS_dx, dx_dpsi, r[3];
};

constexpr size_t kPassBlock = 16;  // groups: their terms (4 KiB) stay in L1

// The products col_i col_j, i in [i0, i1), j >= i, into grey_h[t0 ..] (grey_jac_sums).
template <int i0, int i1, int t0>
ANISO_AVX2_INLINE void grey_sweep(const v8f (*col)[5], size_t count, bool first, LaneSums* acc) {
  constexpr int n = (i1 - i0) * (11 - i0 - i1) / 2;  // 9 and 6
  v8f h[n];
  for (int k = 0; k < n; ++k) h[k] = first ? splat(0.f) : acc->grey_h[t0 + k];
  for (size_t b = 0; b < count; ++b) {
    int tt = 0;
    for (int i = i0; i < i1; ++i)
      for (int j = i; j < 5; ++j) h[tt++] += col[b][i] * col[b][j];
  }
  for (int k = 0; k < n; ++k) acc->grey_h[t0 + k] = h[k];
}

// pass_f32's J^T J and J^T r sums over the block's groups where every light is grey. Channel k's
// row of J is (a, b, ks_k c, kd_k d + ks_k e) with a = W sL, b = W S, c = W dS/dlog n,
// d = W dD/dpsi and e = W dS/dx dx/dpsi the same in the three channels: J^T J takes the 15
// products of a .. e once (grey_assemble scales them per channel), J^T r five sums a channel; 36
// multiply-adds a group where the channels apart take 66.
ANISO_AVX2_INLINE void grey_jac_sums(const TexelLanes& t, size_t g0, size_t count,
                                     const GroupTerms* terms, LaneSums* acc) {
  const bool first = g0 == 0;  // the sums start here (no memset: two `rep stos` a pass)
  v8f col[kPassBlock][5];
  for (size_t b = 0; b < count; ++b) {
    const GroupTerms& e = terms[b];
    const v8f w = load8(t.f.data() + ((g0 + b) * TexelLanes::kRows + 5) * 8);
    col[b][0] = w * e.sL, col[b][1] = w * e.S, col[b][2] = w * e.dS_dlogn;
    col[b][3] = w * e.dD_dpsi, col[b][4] = w * (e.dS_dx * e.dx_dpsi);
  }
  // The products in two sweeps (9 and 6 sums) that fit the registers, then each channel's five.
  grey_sweep<0, 2, 0>(col, count, first, acc);
  grey_sweep<2, 5, 9>(col, count, first, acc);
  for (int k = 0; k < 3; ++k) {
    v8f g[5];
    for (int i = 0; i < 5; ++i) g[i] = first ? splat(0.f) : acc->grey_g[k][i];
    for (size_t b = 0; b < count; ++b)
      for (int i = 0; i < 5; ++i) g[i] += col[b][i] * terms[b].r[k];
    for (int i = 0; i < 5; ++i) acc->grey_g[k][i] = g[i];
  }
}

// Channel k's J^T J (upper triangle, the order of pass_f32's h) and J^T r from grey_jac_sums'.
ANISO_AVX2 void grey_assemble(const LaneSums& acc, const float kd[3], const float ks[3],
                              ChannelSums<8>* s) {
  double P[5][5], G[5];
  for (int i = 0, tt = 0; i < 5; ++i)
    for (int j = i; j < 5; ++j) P[i][j] = P[j][i] = hsum(acc.grey_h[tt++]);
  for (int k = 0; k < 3; ++k) {
    const double d = kd[k], e = ks[k];
    for (int i = 0; i < 5; ++i) G[i] = hsum(acc.grey_g[k][i]);
    double* h = s->h[k];
    h[0] += P[0][0], h[1] += P[0][1], h[2] += e * P[0][2], h[3] += d * P[0][3] + e * P[0][4];
    h[4] += P[1][1], h[5] += e * P[1][2], h[6] += d * P[1][3] + e * P[1][4];
    h[7] += e * e * P[2][2], h[8] += e * (d * P[2][3] + e * P[2][4]);
    h[9] += d * d * P[3][3] + 2 * d * e * P[3][4] + e * e * P[4][4];
    double* g = s->g[k];
    g[0] += G[0], g[1] += G[1], g[2] += e * G[2], g[3] += d * G[3] + e * G[4];
  }
}

// The pass in blocks of groups: first every group's shared terms, residuals and cost (in group
// order, as before), then channel by channel the J^T J and J^T r sums over the block. A channel's
// 15 sums nearly fit the 16 registers where all 43 at once lived on the stack, loaded and stored
// around every multiply-add. Each sum still adds its groups in order; the compiler fuses the split
// expressions' multiply-adds differently, so the sums move in their last bits (the maps of the
// bench sets by at most 1.1e-3 sigma).
ANISO_AVX2 void pass_f32(const TexelLanes& t, const LinePixelParams& p, bool jac,
                         ChannelSums<8>* sums) {
  // The sums this pass adds to start from zero in registers at the first block, not from a
  // memset of them (two `rep stos` a pass: 11 % of the pass's samples, at ~10 groups a texel).
  LaneSums acc;
  acc.cost = splat(0.f);
  if (t.groups == 0) std::memset(&acc, 0, sizeof acc);  // no block to start them
  const v8f c = splat(static_cast<float>(p.c)), sn = splat(static_cast<float>(p.sn));
  const v8f n = splat(static_cast<float>(p.n)), one = splat(1.f), zero = splat(0.f);
  v8f kd[3], ks[3];
  for (int k = 0; k < 3; ++k)
    kd[k] = splat(static_cast<float>(p.kd[k])), ks[k] = splat(static_cast<float>(p.ks[k]));
  constexpr size_t kBlock = kPassBlock;
  GroupTerms terms[kBlock];
  for (size_t g0 = 0; g0 < t.groups; g0 += kBlock) {
    const size_t count = std::min(kBlock, t.groups - g0);
    // In three sweeps over the block, each short enough for the core to run several groups at
    // once: the lobe's chain (dot products, square roots, log, exp) is ~160 cycles of latency a
    // group, and one loop over it left the core waiting on it (2x the time). The sweeps pass
    // their values through `terms` (L1): x in S, x or 1 in dS_dx, log of that in dS_dlogn.
    for (size_t b = 0; b < count; ++b) {
      const Group q = load_group(t.f.data() + (g0 + b) * TexelLanes::kRows * 8);
      GroupTerms& e = terms[b];
      const v8f bv = clamp_unit(c * q.Vu + sn * q.Vw), db = c * q.Vw - sn * q.Vu;
      const v8f a = clamp_unit(c * q.Lu + sn * q.Lw), da = c * q.Lw - sn * q.Lu;
      v8f sV, dsV, dsL;
      vsin(bv, &sV, &dsV);
      vsin(a, &e.sL, &dsL);
      const v8f x = e.sL * sV - a * bv;
      e.S = x;
      e.dS_dx = select(x > zero, x, one);
      e.dx_dpsi = (dsL * sV - bv) * da + (e.sL * dsV - a) * db;
      e.dD_dpsi = dsL * da;
    }
    for (size_t b = 0; b < count; ++b) terms[b].dS_dlogn = vlog(terms[b].dS_dx);
    for (size_t b = 0; b < count; ++b) {
      const float* g = t.f.data() + (g0 + b) * TexelLanes::kRows * 8;
      GroupTerms& e = terms[b];
      const v8f xs = e.dS_dx, lx = e.dS_dlogn;
      e.S = select(e.S > zero, vexp(n * lx), zero);
      e.dS_dx = n * e.S / xs, e.dS_dlogn = e.S * n * lx;
      for (int k = 0; k < 3; ++k) {
        // A padding lane has W = y = 0: its r and v are 0, no mask needed.
        e.r[k] = load8(g + 8 * (5 + k)) * (kd[k] * e.sL + ks[k] * e.S) - load8(g + 8 * (8 + k));
        acc.cost += e.r[k] * e.r[k];
      }
    }
    if (!jac) continue;
    if (t.grey_light) {
      grey_jac_sums(t, g0, count, terms, &acc);
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      v8f h[10], g[4];
      const bool first = g0 == 0;
      for (int i = 0; i < 10; ++i) h[i] = first ? splat(0.f) : acc.h[k][i];
      for (int i = 0; i < 4; ++i) g[i] = first ? splat(0.f) : acc.g[k][i];
      for (size_t b = 0; b < count; ++b) {
        const GroupTerms& e = terms[b];
        const v8f w = load8(t.f.data() + ((g0 + b) * TexelLanes::kRows + 5 + k) * 8);
        const v8f r = e.r[k];
        const v8f v[4] = {w * e.sL, w * e.S, w * ks[k] * e.dS_dlogn,
                          w * (kd[k] * e.dD_dpsi + ks[k] * e.dS_dx * e.dx_dpsi)};
        int tt = 0;
        for (int i = 0; i < 4; ++i) {
          g[i] += v[i] * r;
          for (int j = i; j < 4; ++j) h[tt++] += v[i] * v[j];
        }
      }
      for (int i = 0; i < 10; ++i) acc.h[k][i] = h[i];
      for (int i = 0; i < 4; ++i) acc.g[k][i] = g[i];
    }
  }
  const double cost = hsum(acc.cost);
  sums->cost += cost;
  sums->rss += cost;
  if (!jac) return;
  if (t.grey_light) {
    float kdf[3], ksf[3];
    for (int k = 0; k < 3; ++k) kdf[k] = kd[k][0], ksf[k] = ks[k][0];
    grey_assemble(acc, kdf, ksf, sums);
    return;
  }
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 10; ++i) sums->h[k][i] += hsum(acc.h[k][i]);
    for (int i = 0; i < 4; ++i) sums->g[k][i] += hsum(acc.g[k][i]);
  }
}

// nodes_f32's sums over observations j0 .. j0 + count where every light is grey: the three
// channels' columns are the same, so are their dd, ds, ss sums (channel 0's, the same arithmetic);
// only dy and sy are per channel.
ANISO_AVX2_INLINE void grey_node_sums(const TexelLanes& t, size_t j0, size_t count, const v8f* sLs,
                                      const v8f* xs, v8f dd[3], v8f ds[3], v8f ss[3], v8f dy[3],
                                      v8f sy[3]) {
  auto row = [&](size_t j, int k) { return t.f[((j / 8) * TexelLanes::kRows + k) * 8 + j % 8]; };
  // In two sweeps of five and four sums: nine at once did not fit the registers with their
  // operands, and a sum kept in memory waited on its own store every observation.
  v8f sdd = dd[0], sds = ds[0], sss = ss[0], sdy = dy[0], ssy = sy[0];
  for (size_t b = 0; b < count; ++b) {
    const v8f w = splat(row(j0 + b, 5)), y = splat(row(j0 + b, 8));
    const v8f dcol = w * sLs[b], scol = w * xs[b];
    sdd += dcol * dcol;
    sds += dcol * scol;
    sss += scol * scol;
    sdy += dcol * y;
    ssy += scol * y;
  }
  dd[0] = sdd, ds[0] = sds, ss[0] = sss, dy[0] = sdy, sy[0] = ssy;
  v8f sdy1 = dy[1], ssy1 = sy[1], sdy2 = dy[2], ssy2 = sy[2];
  for (size_t b = 0; b < count; ++b) {
    const v8f w = splat(row(j0 + b, 5)), y1 = splat(row(j0 + b, 9)), y2 = splat(row(j0 + b, 10));
    const v8f dcol = w * sLs[b], scol = w * xs[b];
    sdy1 += dcol * y1;
    ssy1 += scol * y1;
    sdy2 += dcol * y2;
    ssy2 += scol * y2;
  }
  dy[1] = sdy1, sy[1] = ssy1, dy[2] = sdy2, sy[2] = ssy2;
}

ANISO_AVX2 void nodes_f32(const TexelLanes& t, const double psi[8], int log2n, KdKsSums out[8]) {
  // cos and sin of the grid's angles once (16 calls a texel were ~9 % of the nodes' time).
  static const std::array<std::array<float, 2>, 32> grid = [] {
    std::array<std::array<float, 2>, 32> g;
    for (int m = 0; m < 32; ++m)
      g[m] = {static_cast<float>(std::cos(texel_grid_angle(m))),
              static_cast<float>(std::sin(texel_grid_angle(m)))};
    return g;
  }();
  v8f c, sn;
  for (int i = 0; i < 8; ++i) {
    const long m = std::lround(psi[i] * 32 / M_PI);
    if (m >= 0 && m < 32 && psi[i] == texel_grid_angle(static_cast<int>(m)))
      c[i] = grid[m][0], sn[i] = grid[m][1];
    else
      c[i] = static_cast<float>(std::cos(psi[i])), sn[i] = static_cast<float>(std::sin(psi[i]));
  }
  const v8f zero = splat(0.f);
  // Node i's sums over the texel's observations, lane i; the observations go one at a time (a
  // group's lane j splatted), in blocks: first each one's sin(L) and x^n at the eight nodes, then
  // channel by channel the five sums, which then stay in registers.
  v8f dd[3], ds[3], ss[3], dy[3], sy[3];
  for (int k = 0; k < 3; ++k) dd[k] = ds[k] = ss[k] = dy[k] = sy[k] = zero;
  constexpr size_t kBlock = 64;  // observations: their terms (4 KiB) stay in L1
  v8f sLs[kBlock], xs[kBlock];
  // Row k of observation j (lane j % 8 of group j / 8).
  auto row = [&](size_t j, int k) { return t.f[((j / 8) * TexelLanes::kRows + k) * 8 + j % 8]; };
  for (size_t j0 = 0; j0 < t.count; j0 += kBlock) {
    const size_t count = std::min(kBlock, t.count - j0);
    for (size_t b = 0; b < count; ++b) {
      const size_t j = j0 + b;
      const v8f bv = clamp_unit(c * splat(row(j, 0)) + sn * splat(row(j, 1)));
      const v8f a = clamp_unit(c * splat(row(j, 2)) + sn * splat(row(j, 3)));
      v8f sV, unused;
      vsin(bv, &sV, &unused);
      vsin(a, &sLs[b], &unused);
      xs[b] = vmax(sLs[b] * sV - a * bv, zero);
    }
    // x^n by squaring, eight observations' chains side by side in registers: inside the loop
    // above each observation's chain of log2n products was most of the time, and a sweep over
    // the block per product waited on its stores.
    size_t b = 0;
    for (; b + 8 <= count; b += 8) {
      v8f r[8];
      for (int u = 0; u < 8; ++u) r[u] = xs[b + u];
      for (int i = 0; i < log2n; ++i)
        for (int u = 0; u < 8; ++u) r[u] *= r[u];
      for (int u = 0; u < 8; ++u) xs[b + u] = r[u];
    }
    for (; b < count; ++b)
      for (int i = 0; i < log2n; ++i) xs[b] *= xs[b];
    if (t.grey_light) {
      grey_node_sums(t, j0, count, sLs, xs, dd, ds, ss, dy, sy);
      continue;
    }
    for (int ch = 0; ch < 3; ++ch) {
      v8f sdd = dd[ch], sds = ds[ch], sss = ss[ch], sdy = dy[ch], ssy = sy[ch];
      for (size_t b = 0; b < count; ++b) {
        const v8f w = splat(row(j0 + b, 5 + ch)), y = splat(row(j0 + b, 8 + ch));
        const v8f dcol = w * sLs[b], scol = w * xs[b];
        sdd += dcol * dcol;
        sds += dcol * scol;
        sss += scol * scol;
        sdy += dcol * y;
        ssy += scol * y;
      }
      dd[ch] = sdd, ds[ch] = sds, ss[ch] = sss, dy[ch] = sdy, sy[ch] = ssy;
    }
  }
  if (t.grey_light)
    for (int ch = 1; ch < 3; ++ch) dd[ch] = dd[0], ds[ch] = ds[0], ss[ch] = ss[0];
  for (int i = 0; i < 8; ++i)
    for (int ch = 0; ch < 3; ++ch) {
      out[i].dd[ch] = dd[ch][i], out[i].ds[ch] = ds[ch][i], out[i].ss[ch] = ss[ch][i];
      out[i].dy[ch] = dy[ch][i], out[i].sy[ch] = sy[ch][i], out[i].yy[ch] = t.yy[ch];
    }
}

}  // namespace

bool texel_lanes(const ObsSet& os, const std::vector<size_t>& idx, TexelLanes* out) {
  if (!line_simd_enabled()) return false;  // the same CPU check and switch as the double lanes
  out->count = idx.size();
  out->groups = (idx.size() + 7) / 8;
  out->f.resize(out->groups * TexelLanes::kRows * 8);
  // The padding lanes of the last group: zero (mask 0 and finite values).
  if (idx.size() % 8)
    for (int k = 0; k < TexelLanes::kRows; ++k)
      std::fill_n(out->f.data() + ((out->groups - 1) * TexelLanes::kRows + k) * 8 + idx.size() % 8,
                  8 - idx.size() % 8, 0.f);
  for (int c = 0; c < 3; ++c) out->yy[c] = 0;
  out->grey_light = true;
  // The records are scattered over the views, each a cache miss unless asked for ahead: the
  // observation 2k ahead, the light of the one k ahead (its record asked for k steps ago).
  constexpr size_t kAhead = 8;
  auto ask = [](const void* p, size_t bytes) {
    __builtin_prefetch(p);
    __builtin_prefetch(static_cast<const char*>(p) + bytes - 1);
  };
  for (size_t j = 0; j < std::min(2 * kAhead, idx.size()); ++j)
    ask(&os.obs[idx[j]], sizeof(Observation));
  for (size_t j = 0; j < idx.size(); ++j) {
    if (j + 2 * kAhead < idx.size()) ask(&os.obs[idx[j + 2 * kAhead]], sizeof(Observation));
    if (j + kAhead < idx.size())
      ask(&os.lights[os.obs[idx[j + kAhead]].first_light], sizeof(ObsLight));
    const Observation& o = os.obs[idx[j]];
    // Checked here, not in a pass of its own ahead: that pass took every record's cache miss
    // without the prefetches.
    if (o.num_lights != 1) return false;
    const ObsLight& l = os.lights[o.first_light];
    float* g = out->f.data() + (j / 8) * TexelLanes::kRows * 8 + j % 8;
    const float row[TexelLanes::kRows] = {o.V.u,  o.V.w,          l.L.u,          l.L.w,
                                          l.L.n,  l.E[0] * l.L.n, l.E[1] * l.L.n, l.E[2] * l.L.n,
                                          o.y[0], o.y[1],         o.y[2],         1.f};
    for (int k = 0; k < TexelLanes::kRows; ++k) g[8 * k] = row[k];
    out->grey_light = out->grey_light && l.E[0] == l.E[1] && l.E[1] == l.E[2];
    for (int c = 0; c < 3; ++c) out->yy[c] += static_cast<double>(row[8 + c]) * row[8 + c];
  }
  return true;
}

void texel_pass_f32(const TexelLanes& t, const LinePixelParams& p, bool jac, ChannelSums<8>* s) {
  pass_f32(t, p, jac, s);
}

void texel_nodes_f32(const TexelLanes& t, const double psi[8], int log2n, KdKsSums out[8]) {
  nodes_f32(t, psi, log2n, out);
}

}  // namespace aniso::fitting
