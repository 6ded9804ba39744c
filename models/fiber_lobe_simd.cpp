// The lobe's quadrature nodes in double lanes (models/fiber_lobe_simd.h).
#include "models/fiber_lobe_simd.h"

#include <cmath>
#include <cstring>

#include "core/cpu.h"
#include "models/quadrature.h"

namespace aniso::fiber_detail {

namespace {

// The kernel at two widths (models/fiber_lobe_kernels.inc), always inlined into the entry points
// below, each compiled for its instruction set: four lanes (AVX2) and eight (AVX-512). The mask
// type is a vector of long, as GCC gives a comparison of doubles: with long long its selects went
// lane by lane through general registers, and eight lanes under AVX2 compared lane by lane too.
// The two widths add a lobe's nodes in other groupings, so their sums differ in the last bits.
// No helper is ever called as a function, so the ABI of a vector return (GCC's -Wpsabi note)
// never applies.
#pragma GCC diagnostic ignored "-Wpsabi"
#define LANES_INLINE __attribute__((always_inline)) inline
namespace w4 {
typedef double vd __attribute__((vector_size(32)));
typedef long vl __attribute__((vector_size(32)));
constexpr int kW = 4;
#include "models/fiber_lobe_kernels.inc"
}  // namespace w4
namespace w8 {
typedef double vd __attribute__((vector_size(64)));
typedef long vl __attribute__((vector_size(64)));
constexpr int kW = 8;
#include "models/fiber_lobe_kernels.inc"
}  // namespace w8

ANISO_AVX2_FMA void nodes0_avx2(LobeNodes<0>* nd, double* sum) { w4::lobe_nodes<0>(nd, sum); }
ANISO_AVX2_FMA void nodes3_avx2(LobeNodes<3>* nd, double* sum) { w4::lobe_nodes<3>(nd, sum); }
ANISO_AVX512 void nodes0_avx512(LobeNodes<0>* nd, double* sum) { w8::lobe_nodes<0>(nd, sum); }
ANISO_AVX512 void nodes3_avx512(LobeNodes<3>* nd, double* sum) { w8::lobe_nodes<3>(nd, sum); }

// 2: AVX-512 (F, DQ, VL), 1: AVX2 and FMA, 0: neither.
int cpu_level() {
  static const int level = [] {
    if (cpu_has_avx512_dq_vl()) return 2;
    return cpu_has_avx2_fma() ? 1 : 0;
  }();
  return level;
}

}  // namespace

int lobe_lanes(int asked) {
  const int level = cpu_level();
  if (asked == 0 || level == 0) return 0;
  return level == 2 && asked < 0 ? 8 : 4;
}

void lobe_nodes_in_lanes(LobeNodes<0>* nodes, double sum[1]) {
  (nodes->width == 8 ? nodes0_avx512 : nodes0_avx2)(nodes, sum);
}
void lobe_nodes_in_lanes(LobeNodes<3>* nodes, double sum[4]) {
  (nodes->width == 8 ? nodes3_avx512 : nodes3_avx2)(nodes, sum);
}

}  // namespace aniso::fiber_detail
