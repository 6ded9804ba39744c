// What this CPU's vector units can do, asked once, and how a kernel is compiled for them: every
// function built for wider lanes than the project's x86-64 baseline is marked with one of the
// ANISO_<lanes> attributes below and called only where the matching cpu_has_* says so (one place
// for both, so a kernel's target and its run-time check cannot drift apart).
#pragma once

namespace aniso {

// AVX2 alone: four double lanes without fused multiply-add, so a kernel keeps the scalar form's
// bits (the loader's frames and lights).
inline bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

// AVX2 and FMA: four double lanes, eight float lanes (the line model's passes, the fiber lobe).
inline bool cpu_has_avx2_fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}

// AVX-512 Foundation: eight double lanes (the loader's light at shared pixels, the start's closed
// form for eight nodes).
inline bool cpu_has_avx512f() {
  static const bool has = __builtin_cpu_supports("avx512f");
  return has;
}

// AVX-512 F, DQ and VL: the texels' sixteen float lanes, the fiber lobe's eight double lanes.
inline bool cpu_has_avx512_dq_vl() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                          __builtin_cpu_supports("avx512vl");
  return has;
}

// AVX-512 F, BW and VL with BMI2: the pixel classifier's sixteen lanes of bytes and floats.
inline bool cpu_has_avx512_bw_vl_bmi2() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("bmi2");
  return has;
}

}  // namespace aniso

// The targets, each with the check above of the same name; *_INLINE for helpers inlined into
// kernels of that target.
#define ANISO_AVX2 __attribute__((target("avx2")))
#define ANISO_AVX2_INLINE __attribute__((target("avx2"), always_inline)) inline
#define ANISO_AVX2_FMA __attribute__((target("avx2,fma")))
#define ANISO_AVX2_FMA_INLINE __attribute__((target("avx2,fma"), always_inline)) inline
#define ANISO_AVX512F __attribute__((target("avx512f")))
#define ANISO_AVX512 __attribute__((target("avx512f,avx512dq,avx512vl,avx2,fma")))
#define ANISO_AVX512_INLINE \
  __attribute__((target("avx512f,avx512dq,avx512vl,avx2,fma"), always_inline)) inline
#define ANISO_AVX512BW __attribute__((target("avx512f,avx512bw,avx512vl,bmi2")))
