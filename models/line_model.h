// Line-lighting model of Banks (1994) as put on graphics hardware by Heidrich & Seidel
// (Heidrich & Seidel §2-4; the OpenGL course notes). docs/models.md §3 is the definition followed
// here, exactly.
//
// A fiber of direction T has a circle of normals; the one used is the projection of L into the
// plane normal to T. With a = <L,T>, b = <V,T>, s_L = sqrt(1-a^2), s_V = sqrt(1-b^2):
//     D(a,b) = s_L                     (= <L,N'>)
//     S(a,b) = ((s_L s_V - a b)^+)^n   (= <V,R>^n)
//     f      = <N,L>^+ (k_d D + k_s S)                    (Banks' self-shadowing)
//            [+ k_d,iso <N,L>^+ + k_s,iso (<N,H>^+)^n_iso]  (isotropic term, Heidrich & Seidel §4)
// and with a second fiber direction T2 (woven cloth) the two lobes are mixed w : (1-w).
// The radiance of one light is E_i f; the pixel is exposure (k_a I_a + sum_i E_i f_i) (§2).
//
// Parameters (bounds, defaults, units): models/params.h, kLineParams. psi is periodic with period
// 180 degrees because every term is unchanged under T -> -T (docs/models.md §1).
//
// Frame: directions are given in the local frame (U, W = N x U, N) of the surface point, where U
// is the reference tangent (docs/models.md §1); then T = cos psi U + sin psi W has local
// coordinates (cos psi, sin psi, 0). Everything here is templated on the scalar so ceres::Jet flows
// through; directions are data (double), parameters may be Jets.
//
// Limits: D and S depend on (a, b) only, which is what lets one 2D texture hold them (§5).
#pragma once
#include "models/local_dir.h"
#include "models/safe_math.h"

namespace aniso {

template <class T>
struct LineParamsT {
  T kd[3];
  T ks[3];
  T n;    // exponent (not its log)
  T psi;  // radians
  bool isotropic = false;
  T kd_iso[3];
  T ks_iso[3];
  T n_iso;
  bool second = false;
  T psi2;  // radians
  T w;     // weight of the first lobe
};

// D and S of docs/models.md §3 for cosines a = <L,T>, b = <V,T>.
template <class T>
void line_DS(const T& a_in, const T& b_in, const T& n, T* D, T* S) {
  const T a = clamp_unit(a_in), b = clamp_unit(b_in);
  const T sL = sin_from_cos(a), sV = sin_from_cos(b);
  *D = sL;
  *S = pos_pow(sL * sV - a * b, n);
}

// One anisotropic lobe (k_d D + k_s S) for the fiber at angle psi, given as its cosine c and
// sine s, per colour channel.
template <class T>
void line_lobe(const T kd[3], const T ks[3], const T& n, const T& c, const T& s, const LocalDir& L,
               const LocalDir& V, T out[3]) {
  const T a = c * L.u + s * L.w;
  const T b = c * V.u + s * V.w;
  T D, S;
  line_DS(a, b, n, &D, &S);
  for (int k = 0; k < 3; ++k) out[k] = kd[k] * D + ks[k] * S;
}

// The cosines and sines of the fiber angles (psi; psi2 where there is a second lobe): constant
// for a material, so a renderer computes them once, not per evaluation.
template <class T>
struct FiberAngles {
  T c1, s1, c2, s2;
};
template <class T>
FiberAngles<T> fiber_angles(const LineParamsT<T>& p) {
  using std::cos;
  using std::sin;
  FiberAngles<T> f{cos(p.psi), sin(p.psi), T(1.0), T(0.0)};
  if (p.second) f.c2 = cos(p.psi2), f.s2 = sin(p.psi2);
  return f;
}

// Reflected radiance per unit irradiance E_i = 1 for one light (the bracket of docs/models.md §3,
// <N,L>^+ included), with p's fiber angles as `fa`. Zero-weight terms are skipped, not evaluated.
template <class T>
void line_reflectance(const LineParamsT<T>& p, const FiberAngles<T>& fa, const LocalDir& L,
                      const LocalDir& V, T out[3]) {
  out[0] = out[1] = out[2] = T(0.0);
  const double nl = L.n;
  if (!(nl > 0.0)) return;  // light below the horizon: Banks' clamp makes everything zero
  T lobe[3];
  line_lobe(p.kd, p.ks, p.n, fa.c1, fa.s1, L, V, lobe);
  if (p.second) {
    T lobe2[3];
    line_lobe(p.kd, p.ks, p.n, fa.c2, fa.s2, L, V, lobe2);
    for (int k = 0; k < 3; ++k) lobe[k] = p.w * lobe[k] + (T(1.0) - p.w) * lobe2[k];
  }
  for (int k = 0; k < 3; ++k) out[k] = nl * lobe[k];
  if (p.isotropic) {
    const double hu = L.u + V.u, hw = L.w + V.w, hn = L.n + V.n;
    const double hl = std::sqrt(hu * hu + hw * hw + hn * hn);
    const double nh = hl > 0.0 ? hn / hl : 0.0;
    const T spec = pos_pow(T(nh), p.n_iso);
    for (int k = 0; k < 3; ++k) out[k] += p.kd_iso[k] * nl + p.ks_iso[k] * spec;
  }
}

// The same, the fiber angles' cosines and sines computed here.
template <class T>
void line_reflectance(const LineParamsT<T>& p, const LocalDir& L, const LocalDir& V, T out[3]) {
  if (!(L.n > 0.0)) {
    out[0] = out[1] = out[2] = T(0.0);
    return;
  }
  line_reflectance(p, fiber_angles(p), L, V, out);
}

}  // namespace aniso
