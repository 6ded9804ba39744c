// fit/ maps: what a maps fit says of its texels in the report (fit/maps/maps_warnings.cpp).
#pragma once
#include "fit/types/fit_types.h"

namespace aniso {

// The report's warnings about maps m, given the images' noise and --maps-iterations (0: not known):
// the global misfit warning restated with the maps' RMS, and counts of texels whose values the
// data know less well than the bounds, that the model does not describe (maps_misfit_texels),
// that the data do not determine (and those between pixel rows), that stopped short. A fit's,
// and the tiles' merge's over the whole grid.
void add_maps_warnings(const TexelMaps& m, double noise, int iterations, FitReport* rep);

}  // namespace aniso
