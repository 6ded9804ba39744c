// The loader's per-pixel geometry in four lanes (fit/pixel_frames.h). Only AVX2, never FMA: a
// fused multiply-add rounds once where the scalar forms round twice, and the point of this file
// is their bits. Every expression below follows its scalar original term by term.
#include "fit/pixel_frames.h"

#include <immintrin.h>

#include "fit/line_simd.h"

namespace aniso::fitting {

namespace {

#define ANISO_AVX2_ONLY __attribute__((target("avx2")))
#define ANISO_AVX2_ONLY_INLINE __attribute__((target("avx2"), always_inline)) inline

typedef double v4d __attribute__((vector_size(32)));

struct V3 {
  v4d x, y, z;
};

ANISO_AVX2_ONLY_INLINE v4d splat(double v) { return v4d{v, v, v, v}; }
ANISO_AVX2_ONLY_INLINE v4d vsqrt(v4d a) { return v4d(_mm256_sqrt_pd(__m256d(a))); }
// a > b per lane (false for NaN), as all-ones or zero bits.
ANISO_AVX2_ONLY_INLINE v4d gt(v4d a, v4d b) {
  return v4d(_mm256_cmp_pd(__m256d(a), __m256d(b), _CMP_GT_OQ));
}
ANISO_AVX2_ONLY_INLINE v4d pick(v4d mask, v4d a, v4d b) {
  return v4d(_mm256_blendv_pd(__m256d(b), __m256d(a), __m256d(mask)));
}
// dot(a, b) = a.x b.x + a.y b.y + a.z b.z, left to right (core/vec.h).
ANISO_AVX2_ONLY_INLINE v4d vdot(const V3& a, const V3& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
// normalize(a): a / length(a) where the length is > 0, else 0.
ANISO_AVX2_ONLY_INLINE V3 vnormalize(const V3& a) {
  const v4d l = vsqrt(vdot(a, a)), ok = gt(l, splat(0.0)), z = splat(0.0);
  return {pick(ok, a.x / l, z), pick(ok, a.y / l, z), pick(ok, a.z / l, z)};
}
ANISO_AVX2_ONLY_INLINE V3 load3(const double (&a)[3][4]) {
  return {v4d{a[0][0], a[0][1], a[0][2], a[0][3]}, v4d{a[1][0], a[1][1], a[1][2], a[1][3]},
          v4d{a[2][0], a[2][1], a[2][2], a[2][3]}};
}
ANISO_AVX2_ONLY_INLINE V3 from(const Vec3& v) { return {splat(v.x), splat(v.y), splat(v.z)}; }
ANISO_AVX2_ONLY_INLINE V3 sub(const V3& a, const V3& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
// The frame's coordinates of d (core/frame.h to_local): along U, W, N.
ANISO_AVX2_ONLY_INLINE void put_local(const V3& d, const V3& U, const V3& W, const V3& N,
                                      LocalDir out[4]) {
  const v4d u = vdot(d, U), w = vdot(d, W), n = vdot(d, N);
  for (int l = 0; l < 4; ++l) out[l] = {u[l], w[l], n[l]};
}

ANISO_AVX2_ONLY_INLINE void store3(const V3& v, double (&a)[3][4]) {
  for (int l = 0; l < 4; ++l) a[0][l] = v.x[l], a[1][l] = v.y[l], a[2][l] = v.z[l];
}

ANISO_AVX2_ONLY void frame_quad(const Vec3& eye, PixelQuad* q) {
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

ANISO_AVX2_ONLY void light_quad(const Light& light, PixelQuad* q) {
  const V3 P = load3(q->P), U = load3(q->fU), W = load3(q->fW), N = load3(q->fN);
  // light_at, a point light
  const V3 dl = sub(from(light.position), P);
  const v4d r = vsqrt(vdot(dl, dl));
  const V3 L = {dl.x / r, dl.y / r, dl.z / r};
  const v4d att = splat(light.attenuation[0]) + splat(light.attenuation[1]) * r +
                  splat(light.attenuation[2]) * r * r;
  const v4d f = splat(1.0) / att;
  const v4d lit = v4d(_mm256_and_pd(__m256d(gt(r, splat(0.0))), __m256d(gt(att, splat(0.0)))));
  put_local(L, U, W, N, q->L);
  const int litm = _mm256_movemask_pd(__m256d(lit));
  for (int l = 0; l < 4; ++l) q->f[l] = f[l], q->lit[l] = (litm >> l) & 1;
}

}  // namespace

bool pixel_quads_enabled() { return line_simd_enabled(); }

void pixel_quad(const Vec3& eye, const Light& point, PixelQuad* q) {
  frame_quad(eye, q);
  light_quad(point, q);
}
void pixel_frame_quad(const Vec3& eye, PixelQuad* q) { frame_quad(eye, q); }
void pixel_light_quad(const Light& point, PixelQuad* q) { light_quad(point, q); }

}  // namespace aniso::fitting
