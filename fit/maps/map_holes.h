// fit/ internal: the texels of --maps that no pixel reaches although texels on both sides of them
// do (a map finer than the images resolve, as on a tilted view's far side), and the values the
// written maps give them: interpolated from the nearest determined texels along their column (or
// their row), not the global values, which a viewer drew as streaks. They stay undetermined.
#pragma once
#include <cstdint>
#include <vector>

#include "fit/types/fit_types.h"

namespace aniso::fitting {

// 1 where texel i (of the rows m holds) is such a hole.
std::vector<uint8_t> interior_holes(const TexelMaps& m);

// The maps' values as written: copies of kd, ks, n, psi_deg and s with the holes filled.
struct WrittenValues {
  std::vector<double> kd, ks, n, psi_deg, s;
};
WrittenValues written_values(const TexelMaps& m);

}  // namespace aniso::fitting
