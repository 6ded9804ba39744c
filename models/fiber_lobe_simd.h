// The specular lobe's quadrature nodes in SIMD lanes (models/fiber_lobe_simd.cpp). fiber_DS
// gathers the Gauss-Legendre nodes of every panel of its lobe (each node's panel centre and half
// width, its abscissa and weight) and evaluates them eight (AVX-512) or four (AVX2) at a time in
// double, for a double (no derivatives) or a ceres::Jet of three (the fused fiber solver's:
// d/d(log n, psi, topology)). Node by node each took four libm calls (sin, cos, log, exp: 70 % of
// a fiber texel's time), and one panel's nodes alone were too few to keep the lanes busy.
// Polynomial sin, cos, exp and log, within a few units in the last place of libm's (test
// FiberModel.LobeInLanesIsTheScalarLobe); the two widths group a lobe's sums differently, so they
// agree to the last bits, not bit for bit. Ceres' Jets (nine and twelve derivatives) keep the
// scalar nodes: the fitter of record checks this path in the tests.
#pragma once
#include <type_traits>

namespace aniso::fiber_detail {

// The nodes of one lobe: each value followed by its NV derivatives (NV = 0: a double), the
// nodes' arrays side by side (structure of arrays).
template <int NV>
struct LobeNodes {
  static constexpr int kSize = NV + 1;
  static constexpr int kMax = 256;  // nodes held before they are evaluated (fiber_DS flushes)
  // The lobe (fiber_detail::Lobe): its peak phi_h, the view's angle phi_v, sLsV, ab, n, g0.
  double phi_h[kSize], phi_v[kSize], sLsV[kSize], ab[kSize], n[kSize], g0[kSize];
  double cos_hv = 1, sin_hv = 0;  // of phi_h - phi_v (values)
  bool relative_to_peak = false;
  int count = 0;
  int width = 4;  // the lanes: 4 (AVX2) or 8 (AVX-512)
  // Node i at mid + half x: mid[k][i], half[k][i] (k = 0 the value, 1 .. NV its derivatives).
  double mid[kSize][kMax], half[kSize][kMax], x[kMax], w[kMax];
};

// Adds the nodes' integral (value, then its derivatives) to sum and empties them, nodes->width at
// a time. Only where lobe_lanes() is not 0: the caller gathers nodes only then.
void lobe_nodes_in_lanes(LobeNodes<0>* nodes, double sum[1]);
void lobe_nodes_in_lanes(LobeNodes<3>* nodes, double sum[4]);

// The lanes `asked` (FiberAccuracy::lanes: -1 the widest, 4, 0) give on this CPU: 8, 4, or 0
// (node by node).
int lobe_lanes(int asked = -1);

// How many derivatives a scalar type carries: 0 for double, N for a ceres::Jet<double, N>
// (found by its DIMENSION), -1 for anything else.
template <class T, class = void>
struct JetDim : std::integral_constant<int, -1> {};
template <>
struct JetDim<double> : std::integral_constant<int, 0> {};
template <class T>
struct JetDim<T, std::void_t<decltype(T::DIMENSION), decltype(T::a)>>
    : std::integral_constant<int, std::is_same_v<decltype(T::a), double> ? int(T::DIMENSION) : -1> {
};
// The scalars whose lobes go to the lanes, and their nodes' type (an empty stand-in for the
// others).
template <class T>
inline constexpr bool kLobeInLanes = JetDim<T>::value == 0 || JetDim<T>::value == 3;
struct NoLobeNodes {};
template <class T>
using LobeNodesOf =
    std::conditional_t<kLobeInLanes<T>, LobeNodes<kLobeInLanes<T> ? JetDim<T>::value : 0>,
                       NoLobeNodes>;

}  // namespace aniso::fiber_detail
