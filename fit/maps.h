// fit/ internal: --maps, per-texel fits of the line model (fit/maps.cpp).
#pragma once
#include "fit/model_fit.h"

namespace aniso::fitting {

TexelMaps fit_texel_maps(const ObsSet& os, const Core& global, int w, int h, bool progress);

}  // namespace aniso::fitting
