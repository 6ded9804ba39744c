// fit/ internal: --maps, per-texel fits of the line model (fit/maps/maps.cpp).
#pragma once
#include "fit/records/texel_grid.h"
#include "fit/solvers/model_fit.h"

namespace aniso {
class ProgressSink;  // core/progress.h
}  // namespace aniso

namespace aniso::fitting {

// The texel rows of --tile i/N: [row0, row1) are the tile's, [band0, band1) are fitted (with
// --smooth, `sweeps` rows beyond its own on either side: a pull reaches that far).
struct TileRows {
  int row0 = 0, row1 = 0, band0 = 0, band1 = 0;
};
TileRows tile_rows(const FitOptions& opt);
// Rows [row0, row1) and the band fitted for them (their --smooth reach on either side).
TileRows rows_with_reach(int row0, int row1, const FitOptions& opt);

// What a fit in bands (fit/maps/maps_bands.h) reuses from band to band: the bins' indices and the
// texels' results, their pages touched by the first band and written over by the others.
struct TexelScratch;
std::shared_ptr<TexelScratch> texel_scratch();
// A band's maps, once joined, handed back: the next band's fit_texel_maps writes its per-texel
// arrays over theirs (a band's ~19 doubles a texel were fresh pages, faulted in and unmapped
// again, band after band).
void reuse_maps(TexelScratch* scratch, TexelMaps&& done);

struct TexelMapOptions {
  int w = 0, h = 0;    // the grid
  TileRows rows;       // the rows to fit and to hold (tile_rows)
  bool ceres = false;  // every texel by Ceres (the reference) instead of LM
  // --smooth: each texel's parameters pulled toward its 4 neighbours' with weight lambda (in units
  // of the texel's own data: 1 = a neighbour one sigma away costs as much as moving one sigma off
  // the texel's best fit), by `sweeps` Jacobi sweeps (a texel sees its neighbours' values of the
  // previous sweep: the answer does not depend on the order, and a tile that fits `sweeps` rows
  // beyond its band reproduces the untiled run exactly).
  double smooth = 0;
  int sweeps = 10;
  const ProgressSink* progress = nullptr;  // core/progress.h; null: silent
  // The fiber model (fiber_order > 0: its quadrature order): every texel also fits s (a flat
  // sample's one topology value, `s` from the global fit) unless the topology is mathematical.
  int fiber_order = 0;
  // Each texel's own order from these (FiberOrderErrors::order_for its values, at most
  // fiber_order); count 0: every texel at fiber_order.
  FiberOrderErrors fiber_order_errors;
  double s = 0;
  int max_iterations = kTexelIterations;  // --maps-iterations: per texel solve (LM or Ceres)
  // --maps-lanes: the line model's texel passes sixteen lanes (AVX-512) where the CPU has them
  // (true), or eight.
  bool wide_lanes = true;
  TexelScratch* scratch = nullptr;  // bands: storage reused (else fresh)
};

// Fits texel rows [rows.band0, rows.band1) of a w x h grid and returns rows [row0, row1), each
// texel by a hand-written Levenberg-Marquardt, or by Ceres (the reference).
TexelMaps fit_texel_maps(const ObsSet& os, const Core& global, const TexelMapOptions& o);

// A band's maps `part` (its rows [part.row0, part.row1)) placed in `whole`, the maps of rows
// [row0, row1) (shaped by the first band placed in it); counts, sums and times added.
void join_band(const TexelMaps& part, int row0, int row1, TexelMaps* whole);

}  // namespace aniso::fitting
