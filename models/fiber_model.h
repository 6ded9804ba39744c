// Fiber cross-section model: parallel cylinders that hide and shadow each other (Poulin &
// Fournier 1990) and climb on each other where packed tight (Hast §3, eq. 5), with a
// topology map (Hast §4). docs/models.md §4 is the definition followed here, exactly.
//
// Cross-section plane: x along B = N x T, y along N. Unit-radius fibers, topology s in [0, 1]:
// climbing angle theta = 60 deg s, period P = 4 cos theta, low fibers at (kP, 0), high fibers at
// (kP + P/2, 2 sin theta). With l, v the normalised projections of L, V into the plane and the
// in-plane normal n(phi) = (sin phi, cos phi):
//     W = int_vis <n,v> dphi                         (= P v_y, identity 1)
//     D = s_L / W int_{vis & lit} <n,l> <n,v> dphi
//     S = 1 / W int_{vis & lit} (<R,V>^+)^n <n,v> dphi,  <R,V> = s_L s_V cos 2(phi - phi_h) - a b
// where phi_l, phi_v are the angles of l, v from N and phi_h = (phi_l + phi_v) / 2 (the normal
// that mirrors L into V; the peak value s_L s_V - a b is the line model's).
//
// How it is evaluated (fast and exact where it can be):
//  - Visibility from 2D circle geometry, not sampling. Along direction d, a front-arc point
//    p = c + n(phi) has the coordinate e = sin(phi - phi_d) across the beam, and <n,d> dphi = de:
//    the weighted measure is plain length across the beam. A fiber c' ahead of c (d.(c' - c) > 0)
//    hides e in (e_c' - 1, e_c' + 1). The copies of one row ahead of c form a contiguous run of k
//    whose shadows chain into a half-line when the row's spacing across the beam P d_y is below
//    2, so each row contributes one half-line or at most two intervals, at any grazing angle.
//  - The diffuse integrand cos(phi - phi_l) cos(phi - phi_v) is integrated in closed form on every
//    visible-and-lit interval.
//  - The specular lobe is integrated by Gauss-Legendre quadrature on panels placed around its
//    peak phi_h at multiples of its width sigma = sqrt((s_L s_V - ab) / (4 n s_L s_V)), clipped to
//    its support cos 2x > ab / (s_L s_V); accurate from n = 1 to 1e4. For a double and the fused
//    solver's Jet of three, every panel's nodes are gathered and evaluated in SIMD lanes
//    (models/fiber_lobe_simd.h); other scalars (Ceres' Jets) node by node.
//  - Everything is templated on the scalar: with ceres::Jet the interval end points carry their
//    derivatives, so the moving limits of the integrals (Leibniz terms) are differentiated too.
//
// Parameters: those of the line model (models/params.h) plus the topology s (kFiberParams).
// Limits: fibers are assumed much smaller than a pixel (one period stands for the footprint).
#pragma once
#include <algorithm>
#include <cmath>

#include "models/fiber_lobe_simd.h"
#include "models/local_dir.h"
#include "models/quadrature.h"
#include "models/safe_math.h"

namespace aniso {

inline constexpr double kMaxClimbRad = M_PI / 3.0;  // theta = 60 deg * s (Hast eq. 5 range)

// Degenerate directions. A light or view exactly in the surface plane (|<N,L>| within rounding)
// is evaluated as its neighbour a hair above the plane, so the model is the limit of its
// neighbours up to the horizon: along the fiber axis the direction has no projection into the
// cross-section plane, and the limit from above is the projection along N (l = (0, 1)), which
// lights and shows the whole front. Below the horizon nothing is lit or seen (docs/models.md §4).
inline constexpr double kHorizonRounding = 1e-12;  // |<N,L>| this small is 0 up to rounding
inline constexpr double kHairAbovePlane = 1e-9;    // where the in-plane limit is evaluated

// Scalar part of a double or a ceres::Jet (`.a`): for the discrete choices (which fiber copy is
// the first ahead), which are piecewise constant in the parameters.
template <class T>
double ceres_value(const T& x) {
  return x.a;
}
inline double ceres_value(double x) { return x; }

// The sine and cosine of x at once: for a ceres::Jet (`.a`, `.v`) the values and derivatives its
// own sin and cos give, bit for bit, from one sine and one cosine of x.a where the two calls took
// two of each (the fiber texels' quadrature spent 18 % of its samples in libm's sincos).
template <class T>
void sin_cos(const T& x, T* s, T* c) {
  const double sa = std::sin(x.a), ca = std::cos(x.a);
  s->a = sa, s->v = ca * x.v;
  c->a = ca, c->v = -sa * x.v;
}
inline void sin_cos(double x, double* s, double* c) { *s = std::sin(x), *c = std::cos(x); }

// Accuracy of the specular quadrature: Gauss-Legendre order per panel.
struct FiberAccuracy {
  int order = 8;
  // The specular lobe's nodes in SIMD lanes (models/fiber_lobe_simd.h): -1 the widest this CPU
  // has (8 with AVX-512, 4 with AVX2 and FMA), 4 at most four, 0 node by node. The tests and the
  // benchmark hold the forms to one another with it.
  int lanes = -1;
};

template <class T>
struct Interval {
  T lo, hi;
};

template <class T, int N>
struct IntervalList {
  Interval<T> v[N];
  int n = 0;
  void add(const T& lo, const T& hi) {
    if (lo < hi && n < N) v[n++] = {lo, hi};
  }
};

namespace fiber_detail {

template <class T>
T tmax(const T& a, const T& b) {
  return a > b ? a : b;
}
template <class T>
T tmin(const T& a, const T& b) {
  return a < b ? a : b;
}

// Shadows (in the across-beam coordinate e relative to fiber c) that the row of fibers
// (x0 + kP, y0) casts on fiber c = (cx, cy) along unit direction (dx, dy), dy > 0.
// Half-lines use +-4 (beyond the front arc [-1, 1]).
template <class T>
void row_shadows(const T& dx, const T& dy, const T& cx, const T& cy, const T& x0, const T& y0,
                 const T& P, IntervalList<T, 8>* sh) {
  using std::ceil;
  using std::floor;
  const double kBeyond = 4.0;
  auto offset = [&](double k) { return dy * (x0 + k * P - cx) - dx * (y0 - cy); };
  const double spacing = ceres_value(dy * P);
  // Below this |d_x| the beam is vertical: a row is ahead exactly when it is higher.
  constexpr double kVertical = 1e-9;
  const double ddx = ceres_value(dx);
  if (std::abs(ddx) < kVertical) {
    if (!(ceres_value(y0) > ceres_value(cy))) return;
    const double kc = ceres_value((cx - x0) / P);
    for (double k = floor(kc) - 2; k <= floor(kc) + 3; k += 1.0) {
      const T o = offset(k);
      sh->add(o - 1.0, o + 1.0);
    }
    return;
  }
  // Copy k is ahead when dx (x0 + kP - cx) + dy (y0 - cy) > 0. Its shadow meets the front arc
  // [-1, 1] only when |offset_k| < 2, i.e. k within (klo, khi).
  const double kstar = ceres_value((cx - x0 - dy * (y0 - cy) / dx) / P);
  const double klo = ceres_value((cx - x0 + (dx * (y0 - cy) - 2.0) / dy) / P);
  const double khi = ceres_value((cx - x0 + (dx * (y0 - cy) + 2.0) / dy) / P);
  if (ddx > 0) {
    const double k0 = floor(kstar) + 1.0;
    if (spacing < 2.0) {
      sh->add(offset(k0) - 1.0, T(kBeyond));
    } else {
      for (double k = std::max(k0, floor(klo)); k <= ceil(khi); k += 1.0)
        sh->add(offset(k) - 1.0, offset(k) + 1.0);
    }
  } else {
    const double k1 = ceil(kstar) - 1.0;
    if (spacing < 2.0) {
      sh->add(T(-kBeyond), offset(k1) + 1.0);
    } else {
      for (double k = std::min(k1, ceil(khi)); k >= floor(klo); k -= 1.0)
        sh->add(offset(k) - 1.0, offset(k) + 1.0);
    }
  }
}

// The part of fiber c's front arc (e in [-1, 1]) that no other fiber hides along d, as angles phi.
template <class T>
IntervalList<T, 6> unhidden_arcs(const T& dx, const T& dy, const T& phi_d, const T& cx, const T& cy,
                                 const T& P, const T& H) {
  using std::asin;
  IntervalList<T, 8> sh;
  row_shadows(dx, dy, cx, cy, T(0.0), T(0.0), P, &sh);
  row_shadows(dx, dy, cx, cy, P * 0.5, H, P, &sh);
  // Sweep [-1, 1] minus the union of shadows: sort shadows by lower end (at most 8).
  for (int i = 1; i < sh.n; ++i)
    for (int j = i; j > 0 && sh.v[j].lo < sh.v[j - 1].lo; --j) std::swap(sh.v[j], sh.v[j - 1]);
  IntervalList<T, 6> out;
  T cur = T(-1.0);
  bool at_start = true;  // cur is the constant arc end -1
  auto to_phi = [&](const T& e, int end) {
    // The arc ends e = ±1 are constants: asin'(±1) is infinite, so map them directly.
    if (!(e > T(-1.0))) return phi_d - M_PI / 2;
    if (!(e < T(1.0))) return phi_d + M_PI / 2;
    (void)end;
    return phi_d + asin(e);
  };
  for (int i = 0; i < sh.n && cur < T(1.0); ++i) {
    if (sh.v[i].lo > cur) {
      const T hi = tmin(sh.v[i].lo, T(1.0));
      out.add(at_start ? phi_d - M_PI / 2 : to_phi(cur, 0), to_phi(hi, 1));
    }
    if (sh.v[i].hi > cur) {
      cur = sh.v[i].hi;
      at_start = false;
    }
  }
  if (cur < T(1.0)) out.add(at_start ? phi_d - M_PI / 2 : to_phi(cur, 0), phi_d + M_PI / 2);
  return out;
}

}  // namespace fiber_detail

namespace fiber_detail {

// The specular lobe of fiber_DS: peak phi_h, the view's angle, width sigma, <R,V> =
// sLsV cos 2(phi - phi_h) - ab with peak g0, exponent n.
template <class T>
struct Lobe {
  const T &phi_h, &phi_v, &sigma, &sLsV, &ab, &n, &g0;
  bool relative_to_peak;
};

// x's value and derivatives into out[0 .. NV] (NV = JetDim<T>), at `stride` apart, and back.
template <int NV, class T>
void jet_out(const T& x, double* out, int stride = 1) {
  if constexpr (NV == 0) {
    out[0] = x;
  } else {
    out[0] = x.a;
    for (int j = 0; j < NV; ++j) out[(1 + j) * stride] = x.v[j];
  }
}
template <int NV, class T>
T jet_in(const double* in) {
  if constexpr (NV == 0) {
    return in[0];
  } else {
    T x;
    x.a = in[0];
    for (int j = 0; j < NV; ++j) x.v[j] = in[1 + j];
    return x;
  }
}

// The lobe's nodes gathered so far evaluated in the lanes and added to *ssum.
template <class T>
void flush_lobe_nodes(LobeNodesOf<T>* nodes, T* ssum) {
  constexpr int NV = JetDim<T>::value;
  double sum[NV + 1] = {};
  lobe_nodes_in_lanes(nodes, sum);
  *ssum += jet_in<NV, T>(sum);
}

// The panel mid +- half's nodes into `nodes` (evaluated first where they would overflow them).
template <class T>
void add_panel_nodes(const T& mid, const T& half, const GaussRule& gr, LobeNodesOf<T>* nodes,
                     T* ssum) {
  constexpr int NV = JetDim<T>::value;
  if (nodes->count + gr.order > nodes->kMax) flush_lobe_nodes(nodes, ssum);
  for (int q = 0; q < gr.order; ++q) {
    const int i = nodes->count++;
    jet_out<NV>(mid, &nodes->mid[0][i], nodes->kMax);
    jet_out<NV>(half, &nodes->half[0][i], nodes->kMax);
    nodes->x[i] = gr.x[q], nodes->w[i] = gr.w[q];
  }
}

// Adds the lobe's integral over [slo, shi] to *ssum: Gauss-Legendre on panels split at
// multiples of sigma around the peak. With `nodes` (a double or a Jet of three, the lanes on),
// the panels' nodes are gathered there for the lanes instead (fiber_DS evaluates them).
template <class T>
void add_lobe_integral(const Lobe<T>& l, const T& slo, const T& shi, const GaussRule& gr, T* ssum,
                       LobeNodesOf<T>* nodes = nullptr) {
  using std::exp;
  using std::log;
  static constexpr double kSplits[] = {-10, -5, -2.5, -1, 0, 1, 2.5, 5, 10};  // in sigmas
  T edge = slo;
  for (int k = 0; k <= 9; ++k) {
    const T next = k < 9 ? l.phi_h + kSplits[k] * l.sigma : shi;
    if (!(next > edge)) continue;
    const T e1 = tmin(next, shi);
    const T half = 0.5 * (e1 - edge), mid = 0.5 * (e1 + edge);
    if constexpr (kLobeInLanes<T>) {
      if (nodes) add_panel_nodes(mid, half, gr, nodes, ssum);
    }
    if (!nodes) {
      // At p = mid + t: cos 2(p - phi_h) and cos(p - phi_v) by the angle sums from the panel's
      // centre, so a node costs one sine and cosine of t (not two cosines).
      T ca, sa, cb, sb;
      sin_cos(T(2.0 * (mid - l.phi_h)), &sa, &ca);
      sin_cos(T(mid - l.phi_v), &sb, &cb);
      for (int q = 0; q < gr.order; ++q) {
        const T t = half * gr.x[q];
        T ct, st;
        sin_cos(t, &st, &ct);
        const T g = l.sLsV * (ca * (1.0 - 2.0 * st * st) - sa * (2.0 * st * ct)) - l.ab;
        if (g > T(0.0))
          *ssum += half * gr.w[q] * exp(l.n * log(l.relative_to_peak ? g / l.g0 : g)) *
                   (cb * ct - sb * st);
      }
    }
    edge = e1;
    if (!(edge < shi)) break;
  }
}

}  // namespace fiber_detail

// D and S of docs/models.md §4 for one fiber direction. Inputs are the components of L and V along
// B and N (lb, ln, vb, vn), the cosines a = <L,T>, b = <V,T>, the exponent and the topology s.
// With `relative_to_peak`, S comes back divided by the line model's S_line = (s_L s_V - ab)^n
// (the integrand is (<R,V> / (s_L s_V - ab))^n): the factor the baked tables store.
template <class T>
void fiber_DS(const T& lb, const T& ln, const T& vb, const T& vn, const T& a, const T& b,
              const T& n, const T& s, const FiberAccuracy& acc, T* D, T* S, T* W_out = nullptr,
              bool relative_to_peak = false) {
  using fiber_detail::tmax;
  using fiber_detail::tmin;
  using std::acos;
  using std::atan2;
  using std::cos;
  using std::exp;
  using std::log;
  using std::sin;
  using std::sqrt;
  *D = T(0.0);
  *S = T(0.0);
  if (W_out) *W_out = T(0.0);
  // Nothing is lit when <N,L> < 0 and nothing visible when <N,V> < 0 (docs/models.md §4); exactly
  // in the plane, the limit from just above it (kHairAbovePlane).
  const T lnh = std::abs(ceres_value(ln)) <= kHorizonRounding ? T(kHairAbovePlane) : ln;
  const T vnh = std::abs(ceres_value(vn)) <= kHorizonRounding ? T(kHairAbovePlane) : vn;
  if (!(lnh > T(0.0)) || !(vnh > T(0.0))) return;
  const T sL = sqrt(lb * lb + lnh * lnh), sV = sqrt(vb * vb + vnh * vnh);
  const T lx = lb / sL, ly = lnh / sL, vx = vb / sV, vy = vnh / sV;
  const T phi_l = atan2(lx, ly), phi_v = atan2(vx, vy);
  const T theta = kMaxClimbRad * s;
  const T P = 4.0 * cos(theta), H = 2.0 * sin(theta);
  const T W = P * vy;  // identity 1: the visible width of one period
  if (W_out) *W_out = W;
  const T phi_h = 0.5 * (phi_l + phi_v);
  const T sLsV = sL * sV, ab = a * b;
  const T g0 = sLsV - ab;  // peak of <R,V>
  const T cdiff = cos(phi_v - phi_l);
  // Specular support |x| < x_max around phi_h, and the lobe width sigma.
  bool spec = g0 > T(0.0);
  T xmax = T(M_PI / 2), sigma = T(1.0);
  if (spec) {
    const T rho = ab / sLsV;
    if (!(rho < T(1.0)))
      spec = false;
    else if (rho > T(-1.0))
      xmax = 0.5 * acos(rho);
    sigma = sqrt(g0 / (4.0 * n * sLsV));
  }
  const GaussRule& gr = gauss_legendre(acc.order);
  T dsum = T(0.0), ssum = T(0.0);
  // The lobe's nodes for the lanes (models/fiber_lobe_simd.h), where they apply (for any other
  // scalar an empty stand-in, never used).
  fiber_detail::LobeNodesOf<T> lanes_nodes, *nodes = nullptr;
  if constexpr (fiber_detail::kLobeInLanes<T>) {
    if (const int width = fiber_detail::lobe_lanes(acc.lanes); spec && width > 0) {
      constexpr int NV = fiber_detail::JetDim<T>::value;
      nodes = &lanes_nodes;
      nodes->width = width;
      nodes->count = 0;
      nodes->relative_to_peak = relative_to_peak;
      const double hv = ceres_value(phi_h) - ceres_value(phi_v);
      nodes->cos_hv = std::cos(hv), nodes->sin_hv = std::sin(hv);
      const T* lobe[6] = {&phi_h, &phi_v, &sLsV, &ab, &n, &g0};
      double* at[6] = {nodes->phi_h, nodes->phi_v, nodes->sLsV, nodes->ab, nodes->n, nodes->g0};
      for (int k = 0; k < 6; ++k) fiber_detail::jet_out<NV>(*lobe[k], at[k]);
    }
  }
  const T cx[2] = {T(0.0), P * 0.5}, cy[2] = {T(0.0), H};
  for (int f = 0; f < 2; ++f) {
    const auto vis = fiber_detail::unhidden_arcs(vx, vy, phi_v, cx[f], cy[f], P, H);
    const auto lit = fiber_detail::unhidden_arcs(lx, ly, phi_l, cx[f], cy[f], P, H);
    for (int i = 0; i < vis.n; ++i)
      for (int j = 0; j < lit.n; ++j) {
        const T lo = tmax(vis.v[i].lo, lit.v[j].lo), hi = tmin(vis.v[i].hi, lit.v[j].hi);
        if (!(lo < hi)) continue;
        // Diffuse: int cos(p - pl) cos(p - pv) = (p/2) cos(pv - pl) + sin(2p - pl - pv) / 4.
        dsum += 0.5 * (hi - lo) * cdiff +
                0.25 * (sin(2.0 * hi - phi_l - phi_v) - sin(2.0 * lo - phi_l - phi_v));
        if (!spec) continue;
        const T slo = tmax(lo, phi_h - xmax), shi = tmin(hi, phi_h + xmax);
        if (!(slo < shi)) continue;
        const fiber_detail::Lobe<T> lobe{phi_h, phi_v, sigma, sLsV, ab, n, g0, relative_to_peak};
        fiber_detail::add_lobe_integral(lobe, slo, shi, gr, &ssum, nodes);
      }
  }
  if constexpr (fiber_detail::kLobeInLanes<T>) {
    if (nodes && nodes->count > 0) fiber_detail::flush_lobe_nodes(nodes, &ssum);
  }
  if (!(W > T(0.0))) return;
  *D = sL * dsum / W;
  *S = ssum / W;
  // At a view within ~1e-13 of the surface W is that small and the rounding of the closed form
  // (about 1e-16) is amplified past the bounds: keep 0 <= D <= s_L (identity 3) and S >= 0. Found
  // by fuzz/fuzz_model.cpp; the clamp only ever moves values that rounding pushed out.
  if (*D < T(0.0)) *D = T(0.0);
  if (*D > sL) *D = sL;
  if (*S < T(0.0)) *S = T(0.0);
}

}  // namespace aniso

namespace aniso {

// Topology helpers (docs/models.md §4, Hast §3-4), templated for the fit.
// The topology value s of a point from its mathematical topology s_math, a map value m in
// [-1, 1] and the map amplitude A: H = clamp(2 sin theta_math + A m, 0, sqrt 3), s =
// asin(H/2)/60deg.
template <class T>
T topology_with_map(double s_math, const T& amplitude, double m) {
  using std::asin;
  T H = 2.0 * std::sin(kMaxClimbRad * s_math) + amplitude * m;
  if (H < T(0.0)) H = T(0.0);
  if (H > T(std::sqrt(3.0))) H = T(std::sqrt(3.0));
  // asin'(1) is infinite; H = sqrt 3 gives H/2 < 1, so the derivative stays finite.
  return asin(0.5 * H) / kMaxClimbRad;
}

// Mathematical topology of a torus with fibers wound around the tube (docs/models.md §4): major
// radius R, minor r, poloidal angle v (0 on the outside). c = (R + r)/(R + r cos v) in [1,
// (R+r)/(R-r)], c' = c / 2^floor(log2 c) in [1, 2), theta = acos(1/c'), s = theta / 60 deg.
inline double torus_mathematical_s(double R, double r, double v) {
  const double c = (R + r) / (R + r * std::cos(v));
  const double cp = c / std::pow(2.0, std::floor(std::log2(c)));
  return std::acos(1.0 / cp) / kMaxClimbRad;
}

// Reflectance per unit irradiance of the fiber model for one light (docs/models.md §4): no <N,L>
// factor (the fibers shadow each other). The optional isotropic term and second fiber direction
// are those of the line model, each skipped when its weight is zero.
template <class T, class P>
void fiber_lobe(const P& p, const T& psi, const T& s, const LocalDir& L, const LocalDir& V,
                const FiberAccuracy& acc, T out[3]) {
  using std::cos;
  using std::sin;
  const T c = cos(psi), sn = sin(psi);
  // T = c U + s W, B = N x T = c W - s U (local frame U, W = N x U, N).
  const T a = c * L.u + sn * L.w, b = c * V.u + sn * V.w;
  const T lb = c * L.w - sn * L.u, vb = c * V.w - sn * V.u;
  T D, S;
  fiber_DS(lb, T(L.n), vb, T(V.n), a, b, p.n, s, acc, &D, &S);
  for (int k = 0; k < 3; ++k) out[k] = p.kd[k] * D + p.ks[k] * S;
}

template <class T, class P>
void fiber_reflectance(const P& p, const T& s, const LocalDir& L, const LocalDir& V,
                       const FiberAccuracy& acc, T out[3]) {
  out[0] = out[1] = out[2] = T(0.0);
  if (L.n < -kHorizonRounding || V.n < -kHorizonRounding) return;  // in the plane: see fiber_DS
  fiber_lobe(p, p.psi, s, L, V, acc, out);
  if (p.second) {
    T lobe2[3];
    fiber_lobe(p, p.psi2, s, L, V, acc, lobe2);
    for (int k = 0; k < 3; ++k) out[k] = p.w * out[k] + (T(1.0) - p.w) * lobe2[k];
  }
  if (p.isotropic) {
    const double hu = L.u + V.u, hw = L.w + V.w, hn = L.n + V.n;
    const double hl = std::sqrt(hu * hu + hw * hw + hn * hn);
    const T spec = pos_pow(T(hl > 0.0 ? hn / hl : 0.0), p.n_iso);
    for (int k = 0; k < 3; ++k) out[k] += p.kd_iso[k] * std::max(L.n, 0.0) + p.ks_iso[k] * spec;
  }
}

}  // namespace aniso
