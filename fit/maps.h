// fit/ internal: --maps, per-texel fits of the line model (fit/maps.cpp).
#pragma once
#include "fit/model_fit.h"

namespace aniso::fitting {

// Fits texel rows [row0, row1) of a w x h grid (the whole grid: 0, h), each texel by a
// hand-written Levenberg-Marquardt, or by Ceres with `ceres_path` (the reference).
TexelMaps fit_texel_maps(const ObsSet& os, const Core& global, int w, int h, int row0, int row1,
                         bool ceres_path, bool progress);

}  // namespace aniso::fitting
