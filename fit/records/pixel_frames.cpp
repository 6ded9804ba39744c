// The loader's per-pixel geometry in four lanes (fit/records/pixel_frames.h), and the light's part
// in eight where the CPU has AVX-512F. Never a fused multiply-add: it rounds once where the scalar
// forms round twice, and the point of this file is their bits (AVX2 has no FMA without asking;
// AVX-512F has, so the file is built with -ffp-contract=off). Every expression below follows its
// scalar original term by term.
#include "fit/records/pixel_frames.h"

#include <immintrin.h>

#include <cstring>

#include "core/cpu.h"
#include "fit/records/observations.h"

namespace aniso::fitting {

namespace {

typedef double v4d __attribute__((vector_size(32)));

struct V3 {
  v4d x, y, z;
};

ANISO_AVX2_INLINE v4d splat(double v) { return v4d{v, v, v, v}; }
ANISO_AVX2_INLINE v4d vsqrt(v4d a) { return v4d(_mm256_sqrt_pd(__m256d(a))); }
// a > b per lane (false for NaN), as all-ones or zero bits.
ANISO_AVX2_INLINE v4d gt(v4d a, v4d b) {
  return v4d(_mm256_cmp_pd(__m256d(a), __m256d(b), _CMP_GT_OQ));
}
ANISO_AVX2_INLINE v4d pick(v4d mask, v4d a, v4d b) {
  return v4d(_mm256_blendv_pd(__m256d(b), __m256d(a), __m256d(mask)));
}
// dot(a, b) = a.x b.x + a.y b.y + a.z b.z, left to right (core/vec.h).
ANISO_AVX2_INLINE v4d vdot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
// normalize(a): a / length(a) where the length is > 0, else 0.
ANISO_AVX2_INLINE V3 vnormalize(const V3& a) {
  const v4d l = vsqrt(vdot(a, a)), ok = gt(l, splat(0.0)), z = splat(0.0);
  return {pick(ok, a.x / l, z), pick(ok, a.y / l, z), pick(ok, a.z / l, z)};
}
ANISO_AVX2_INLINE V3 load3(const double (&a)[3][4]) {
  return {v4d{a[0][0], a[0][1], a[0][2], a[0][3]}, v4d{a[1][0], a[1][1], a[1][2], a[1][3]},
          v4d{a[2][0], a[2][1], a[2][2], a[2][3]}};
}
ANISO_AVX2_INLINE V3 from(const Vec3& v) { return {splat(v.x), splat(v.y), splat(v.z)}; }
ANISO_AVX2_INLINE V3 sub(const V3& a, const V3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
// The frame's coordinates of d (core/frame.h to_local): along U, W, N.
ANISO_AVX2_INLINE void put_local(const V3& d, const V3& U, const V3& W, const V3& N,
                                 LocalDir out[4]) {
  const v4d u = vdot(d, U), w = vdot(d, W), n = vdot(d, N);
  for (int l = 0; l < 4; ++l) out[l] = {u[l], w[l], n[l]};
}

ANISO_AVX2_INLINE void store3(const V3& v, double (&a)[3][4]) {
  for (int l = 0; l < 4; ++l) a[0][l] = v.x[l], a[1][l] = v.y[l], a[2][l] = v.z[l];
}

ANISO_AVX2 void frame_quad(const Vec3& eye, PixelQuad* q) {
  const V3 P = load3(q->P), N_in = load3(q->N), U_in = load3(q->U);
  // make_frame
  const V3 N = vnormalize(N_in);
  const v4d d = vdot(U_in, N);
  V3 U = {U_in.x - N.x * d, U_in.y - N.y * d, U_in.z - N.z * d};
  constexpr double kMinTangent = 1e-6;  // make_frame's
  const v4d ok = v4d(_mm256_and_pd(__m256d(gt(vsqrt(vdot(N, N)), splat(0.5))),
                                   __m256d(gt(vsqrt(vdot(U, U)), splat(kMinTangent)))));
  U = vnormalize(U);
  const V3 W = {N.y * U.z - N.z * U.y, N.z * U.x - N.x * U.z, N.x * U.y - N.y * U.x};
  // V = normalize(eye - P)
  put_local(vnormalize(sub(from(eye), P)), U, W, N, q->V);
  store3(U, q->fU), store3(W, q->fW), store3(N, q->fN);
  const int okm = _mm256_movemask_pd(__m256d(ok));
  for (int l = 0; l < 4; ++l) q->frame_ok[l] = (okm >> l) & 1;
}

// light_at for a point light and to_local, over lanes of any width (VD a vector of doubles), in
// two parts around the square root of *r2, which the caller takes in its own target: the first
// gives dl = light - P and its squared length, the second L in the frame (U, W, N), the
// attenuation factor f and *lit, all ones (a NaN) where the light reaches the point, else 0.
// Inlined into the callers below, which give them their target; vectors pass by pointer only.
template <class VD>
__attribute__((always_inline)) inline void light_dist(const Light& light, const VD* P, VD* dl,
                                                      VD* r2) {
  dl[0] = light.position.x - P[0], dl[1] = light.position.y - P[1], dl[2] = light.position.z - P[2];
  *r2 = dl[0] * dl[0] + dl[1] * dl[1] + dl[2] * dl[2];
}
template <class VD>
__attribute__((always_inline)) inline void light_local(const Light& light, const VD* dl,
                                                       const VD* r, const VD* U, const VD* W,
                                                       const VD* N, VD* L_out, VD* f, VD* lit) {
  const VD L[3] = {dl[0] / *r, dl[1] / *r, dl[2] / *r};
  const VD att = light.attenuation[0] + light.attenuation[1] * *r + light.attenuation[2] * *r * *r;
  *f = 1.0 / att;
  *lit = (VD)((*r > 0.0) & (att > 0.0));
  L_out[0] = L[0] * U[0] + L[1] * U[1] + L[2] * U[2];
  L_out[1] = L[0] * W[0] + L[1] * W[1] + L[2] * W[2];
  L_out[2] = L[0] * N[0] + L[1] * N[1] + L[2] * N[2];
}

ANISO_AVX2 void light_quad(const Light& light, PixelQuad* q) {
  const V3 P = load3(q->P), U = load3(q->fU), W = load3(q->fW), N = load3(q->fN);
  const v4d Pv[3] = {P.x, P.y, P.z}, Uv[3] = {U.x, U.y, U.z}, Wv[3] = {W.x, W.y, W.z},
            Nv[3] = {N.x, N.y, N.z};
  v4d dl[3], r2, L[3], f, lit;
  light_dist(light, Pv, dl, &r2);
  const v4d r = vsqrt(r2);
  light_local(light, dl, &r, Uv, Wv, Nv, L, &f, &lit);
  const int litm = _mm256_movemask_pd(__m256d(lit));
  for (int l = 0; l < 4; ++l)
    q->L[l] = {L[0][l], L[1][l], L[2][l]}, q->f[l] = f[l], q->lit[l] = (litm >> l) & 1;
}

// shared_light_lanes' lanes [at, at + width) of the rows from index i: their rows, then the
// second part after the caller's square root of r2.
template <class VD>
__attribute__((always_inline)) inline void shared_rows(const Light& light, const double* frame,
                                                       size_t padded, size_t i, VD* rows, VD* dl,
                                                       VD* r2) {
  for (int k = 0; k < 12; ++k) std::memcpy(&rows[k], frame + k * padded + i, sizeof(VD));
  light_dist(light, rows, dl, r2);
}
template <class VD>
__attribute__((always_inline)) inline void shared_out(const Light& light, const VD* rows,
                                                      const VD* dl, const VD* r, int at,
                                                      LightLanes* out) {
  VD L[3], f, lit;
  light_local(light, dl, r, rows + 3, rows + 6, rows + 9, L, &f, &lit);
  constexpr int width = sizeof(VD) / sizeof(double);
  for (int l = 0; l < width; ++l)
    out->L[at + l] = {L[0][l], L[1][l], L[2][l]}, out->f[at + l] = f[l],
                out->lit[at + l] = lit[l] != 0;
}

ANISO_AVX2 void shared_lanes_avx2(const Light& light, const double* frame, size_t padded, size_t i,
                                  LightLanes* out) {
  for (int at = 0; at < kSharedLanes; at += 4) {
    v4d rows[12], dl[3], r2;
    shared_rows(light, frame, padded, i + at, rows, dl, &r2);
    const v4d r = vsqrt(r2);
    shared_out(light, rows, dl, &r, at, out);
  }
}

// Eight lanes in one (AVX-512F's fused multiply-add is not used: the file is built with
// -ffp-contract=off, so a * b + c rounds twice as in the scalar form).
typedef double v8d __attribute__((vector_size(64)));
ANISO_AVX512F void shared_lanes_avx512(const Light& light, const double* frame, size_t padded,
                                       size_t i, LightLanes* out) {
  v8d rows[12], dl[3], r2;
  shared_rows(light, frame, padded, i, rows, dl, &r2);
  // The builtin itself: _mm512_sqrt_pd's undefined pass-through trips GCC 12's maybe-uninitialized.
  const v8d r = __builtin_ia32_sqrtpd512_mask(r2, r2, 0xff, 4);
  shared_out(light, rows, dl, &r, 0, out);
}

}  // namespace

bool line_lanes_on(bool asked) { return asked && cpu_has_avx2_fma(); }
bool line_lanes_on(const ObsSet& os) { return line_lanes_on(os.simd); }

void pixel_quad(const Vec3& eye, const Light& point, PixelQuad* q) {
  frame_quad(eye, q);
  light_quad(point, q);
}
void pixel_frame_quad(const Vec3& eye, PixelQuad* q) { frame_quad(eye, q); }
void pixel_light_quad(const Light& point, PixelQuad* q) { light_quad(point, q); }

void shared_light_lanes(const Light& point, const double* frame, size_t padded, size_t i,
                        bool avx512, LightLanes* out) {
  if (avx512 && cpu_has_avx512f())
    shared_lanes_avx512(point, frame, padded, i, out);
  else
    shared_lanes_avx2(point, frame, padded, i, out);
}

}  // namespace aniso::fitting
