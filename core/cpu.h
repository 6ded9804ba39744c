// What this CPU's vector units can do, asked once: kernels built for wider lanes than the
// project's baseline are chosen by these at run time.
#pragma once

namespace aniso {

// AVX-512 Foundation: eight double lanes (the loader's light at shared pixels, the start's closed
// form for eight nodes).
inline bool cpu_has_avx512f() {
  static const bool has = __builtin_cpu_supports("avx512f");
  return has;
}

}  // namespace aniso
