// fit/ internal: --maps, per-texel fits of the line model (fit/maps.cpp).
#pragma once
#include "fit/model_fit.h"

namespace aniso::fitting {

struct TexelMapOptions {
  int w = 0, h = 0, row0 = 0, row1 = 0;  // the grid, and the rows to fit (all: 0, h)
  bool ceres = false;                    // every texel by Ceres (the reference) instead of LM
  // --smooth: each texel's parameters pulled toward its 4 neighbours' with weight lambda (in units
  // of the texel's own data: 1 = a neighbour one sigma away costs as much as moving one sigma off
  // the texel's best fit), by `sweeps` Jacobi sweeps (a texel sees its neighbours' values of the
  // previous sweep: the answer does not depend on the order, and a tile that fits `sweeps` rows
  // beyond its band reproduces the untiled run exactly).
  double smooth = 0;
  int sweeps = 10;
  bool progress = false;
  // The fiber model (fiber_order > 0: its quadrature order): every texel also fits s (a flat
  // sample's one topology value, `s` from the global fit) unless the topology is mathematical.
  int fiber_order = 0;
  double s = 0;
};

// Fits texel rows [row0, row1) of a w x h grid, each texel by a hand-written
// Levenberg-Marquardt, or by Ceres (the reference).
TexelMaps fit_texel_maps(const ObsSet& os, const Core& global, const TexelMapOptions& o);

}  // namespace aniso::fitting
