#include "fit/solvers/texel_lanes.h"

#include <immintrin.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>

#include "core/cpu.h"
#include "fit/solvers/line_pixel_lanes.h"
#include "fit/solvers/start.h"

namespace aniso::fitting {

namespace {

// GCC's vector types: eight floats (one AVX2 register).
typedef float v8f __attribute__((vector_size(32)));

ANISO_AVX2_FMA_INLINE v8f load8(const float* p) {
  v8f v;
  std::memcpy(&v, p, sizeof v);  // one unaligned 32-byte load
  return v;
}

// The eight lanes' sum in double: the halves widened and added, then pairwise (eight additions
// in a row were a chain of 32 cycles, ~100 of them a pass).
ANISO_AVX2_FMA_INLINE double hsum8(v8f v) {
  const __m256d a = _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(__m256(v))),
                                  _mm256_cvtps_pd(_mm256_extractf128_ps(__m256(v), 1)));
  const __m128d b = _mm_add_pd(_mm256_castpd256_pd128(a), _mm256_extractf128_pd(a, 1));
  return _mm_cvtsd_f64(_mm_add_sd(b, _mm_unpackhi_pd(b, b)));
}

// The kernels eight lanes wide (AVX2 and FMA): a lane an observation in the pass, a node in the
// start's nodes.
namespace x8 {
typedef float vf __attribute__((vector_size(32)));
typedef int vi __attribute__((vector_size(32)));
constexpr int kWidth = 8, kLanes = 1;
#define TK_TARGET ANISO_AVX2_FMA
#define TK_INLINE ANISO_AVX2_FMA_INLINE
TK_INLINE vf splat(float x) { return vf{x, x, x, x, x, x, x, x}; }
TK_INLINE vf vsqrt(vf a) { return __builtin_ia32_sqrtps256(a); }
TK_INLINE double hsum(vf v) { return hsum8(v); }
TK_INLINE vf load_row(const float* f, size_t G, int k) {
  return load8(f + (G * TexelLanes::kRows + k) * 8);
}
TK_INLINE vf node_row(const float* f, size_t j, int k) {
  return splat(f[((j / 8) * TexelLanes::kRows + k) * 8 + j % 8]);
}
#include "fit/solvers/texel_lanes_kernels.inc"
#undef TK_TARGET
#undef TK_INLINE
}  // namespace x8

// Sixteen lanes wide (AVX-512): two groups of the lanes a register in the pass, two observations'
// eight nodes in the start's (1.6-1.8x the nodes' rate of eight lanes here, aniso_microbench).
// The sums add in another order than eight lanes': the same to float's rounding, not bit for bit.
namespace x16 {
typedef float vf __attribute__((vector_size(64)));
typedef int vi __attribute__((vector_size(64)));
typedef double v8d __attribute__((vector_size(64)));
constexpr int kWidth = 16, kLanes = 2;
#define TK_TARGET ANISO_AVX512
#define TK_INLINE ANISO_AVX512_INLINE
TK_INLINE vf splat(float x) { return vf{x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x}; }
// The builtin itself: _mm512_sqrt_ps's undefined pass-through trips GCC 12's maybe-uninitialized.
TK_INLINE vf vsqrt(vf a) { return __builtin_ia32_sqrtps512_mask(a, a, 0xffff, 4); }
TK_INLINE double hsum(vf v) {  // the halves added in float, then as eight lanes
  return hsum8(__builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7) +
               __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15));
}
TK_INLINE vf load_row(const float* f, size_t G, int k) {
  const v8f lo = load8(f + (2 * G * TexelLanes::kRows + k) * 8);
  const v8f hi = load8(f + ((2 * G + 1) * TexelLanes::kRows + k) * 8);
  return __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
}
TK_INLINE vf node_row(const float* f, size_t j, int k) {
  // j even: j + 1 beside it. The pair as one double broadcast (one vbroadcastsd; a pair built
  // as a 4-float vector went through the stack and stalled on its store).
  double two;
  std::memcpy(&two, f + ((j / 8) * TexelLanes::kRows + k) * 8 + j % 8, sizeof two);
  return (vf)v8d{two, two, two, two, two, two, two, two};
}
#include "fit/solvers/texel_lanes_kernels.inc"
#undef TK_TARGET
#undef TK_INLINE
}  // namespace x16

}  // namespace

bool texel_lanes(const ObsSet& os, const std::vector<size_t>& idx, TexelLanes* out, bool wide) {
  if (!line_lanes_on(os)) return false;  // the same CPU check and option as the double lanes
  out->wide = wide && cpu_has_avx512_dq_vl();
  out->count = idx.size();
  out->groups = (idx.size() + 7) / 8;
  out->f.resize(TexelLanes::stored_groups(out->groups) * TexelLanes::kRows * 8);
  std::fill(out->f.begin() + out->groups * TexelLanes::kRows * 8, out->f.end(), 0.f);
  // The padding lanes of the last group: zero (mask 0 and finite values).
  if (idx.size() % 8)
    for (int k = 0; k < TexelLanes::kRows; ++k)
      std::fill_n(out->f.data() + ((out->groups - 1) * TexelLanes::kRows + k) * 8 + idx.size() % 8,
                  8 - idx.size() % 8, 0.f);
  for (int c = 0; c < 3; ++c) out->yy[c] = 0;
  out->grey_light = true;
  // The records are scattered over the views, each a cache miss unless asked for ahead: the
  // observation 2k ahead, the light of the one k ahead (its record asked for k steps ago).
  // Where every record has one light, record i's is light i (the loader closes both arrays'
  // gaps alike): its light is asked for with it, not once its record is in (a chain of two misses,
  // half of this function's time).
  constexpr size_t kAhead = 8;
  const bool paired = os.lights.size() == os.obs.size();
  auto ask = [](const void* p, size_t bytes) {
    __builtin_prefetch(p);
    __builtin_prefetch(static_cast<const char*>(p) + bytes - 1);
  };
  auto ask_record = [&](size_t i) {
    ask(&os.obs[i], sizeof(Observation));
    if (paired) ask(&os.lights[i], sizeof(ObsLight));
  };
  for (size_t j = 0; j < std::min(2 * kAhead, idx.size()); ++j) ask_record(idx[j]);
  for (size_t j = 0; j < idx.size(); ++j) {
    if (j + 2 * kAhead < idx.size()) ask_record(idx[j + 2 * kAhead]);
    if (!paired && j + kAhead < idx.size())
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

bool texel_avx512_available() { return cpu_has_avx512_dq_vl(); }

int texel_float_lanes(bool simd, bool wide) {
  return !line_lanes_on(simd) ? 0 : wide && texel_avx512_available() ? 16 : 8;
}

void texel_pass_f32(const TexelLanes& t, const LinePixelParams& p, bool jac, ChannelSums<8>* s) {
  if (t.wide)
    x16::pass_f32(t, p, jac, s);
  else
    x8::pass_f32(t, p, jac, s);
}

void texel_nodes_f32(const TexelLanes& t, const double psi[8], int log2n, KdKsSums out[8]) {
  if (t.wide)
    x16::nodes_f32(t, psi, log2n, out);
  else
    x8::nodes_f32(t, psi, log2n, out);
}

}  // namespace aniso::fitting
