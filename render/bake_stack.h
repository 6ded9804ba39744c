// The line model's specular table at many n (ours, for materials with a map of n): levels of
// S(a, b; n) at n spaced evenly in log n over the map's range, on the same grid and index as the
// table they stand beside (render/bake.h). The shader takes S bilinearly from the two levels
// either side of its fragment's log n and blends them with its own exact weight; k_d, k_s and the
// fiber direction come from their maps per fragment. The error of that lookup against S itself is
// measured at bake time over random (a, b, n), as bake_line measures its tables.
#pragma once
#include <cstdint>
#include <vector>

#include "core/image.h"
#include "render/bake.h"

namespace aniso {

struct SpecularStack {
  int size = 0, levels = 0;
  BakeIndex index = BakeIndex::kAngle;
  double logn0 = 0, logn1 = 0;  // log n of the first and the last level
  std::vector<Image> S;         // one 1-channel size x size table per level
  // |stack lookup - S| over `samples` random (a, b) at random n in the range, plus the lobe's
  // ridge; |bilinear D - D| over the same (a, b). Max over samples.
  double max_abs_error = 0, diffuse_max_abs_error = 0;
  // Largest step between neighbouring texels of any level (what GL_LINEAR's weights may add).
  double max_texel_step = 0;
  size_t samples = 0;
  uint64_t seed = 0;
  double log_step() const { return levels > 1 ? (logn1 - logn0) / (levels - 1) : 0.0; }
};

// Levels at most `max_log_step` apart in log n (at least 2, at most `max_levels`) over
// [n_min, n_max], each on `size` texels of `index`. Throws on a range that is not finite and
// positive.
SpecularStack bake_specular_stack(double n_min, double n_max, int size, BakeIndex index,
                                  double max_log_step = 0.05, int max_levels = 64,
                                  uint64_t seed = 1);

// What the shader computes, on the CPU: S at (a, b) and n from the stack.
double stack_lookup(const SpecularStack& st, double a, double b, double n);

// The smallest and largest finite positive value of channel 0 of `img`; false where there is none.
bool map_range(const Image& img, double* lo, double* hi);

}  // namespace aniso
