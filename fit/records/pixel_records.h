// fit/ internal: a view's pixels to records (fit/records/observations.cpp's loader): where they go,
// the tile's band of texels, and each usable pixel's frame, V and lights in it.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/vec.h"
#include "fit/records/observations.h"
#include "fit/records/texel_grid.h"
#include "io/formats/capture.h"

namespace aniso::fitting {

// Where a view's records go: obs and lights at these places of the set's arrays (room for every
// usable pixel of the stride grid), the lights numbered from light_base.
struct RecordSlot {
  Observation* obs;
  ObsLight* lights;
  uint32_t light_base;
  float* uv = nullptr;                 // two per observation, where kept
  uint32_t* texel = nullptr;           // one per observation, where kept
  float* topo = nullptr;               // two per observation, where kept
  size_t num_obs = 0, num_lights = 0;  // written
  // Bands: a value above this (a --global fit's limit) is left out as implausible here, where
  // one load of every pixel drops it afterwards (0: not here).
  double implausible = 0;
};

// --maps: the w x h grid of the maps (w = 0 without). With --global the maps are fitted band by
// band of texel rows (fit/maps/maps_bands.cpp; one band where the records fit in --maps-memory) and
// a band's load keeps only the pixels of its texels: [k0, k1), its rows with the --smooth reach on
// either side, within --tile's [t0, t1) where `tile` (its rows [tile_o0, tile_o1) and their
// reach; the pixels outside its rows are other tiles'). It counts pixels (kept, left out, unlit)
// only for its own texels [o0, o1): every pixel is counted by one band, and by one tile. A pixel
// with no texel (uv outside [0, 1)^2) is the first band's (of the first tile, which counts it but
// keeps no record of it).
struct UvBand {
  int w = 0, h = 0;
  bool banded = false;
  bool tile = false, first_tile = true;
  long t0 = 0, t1 = 0, tile_o0 = 0, tile_o1 = 0;
  bool first = true;
  long k0 = 0, k1 = 0, o0 = 0, o1 = 0;
  long texel(const ViewData& d, int x, int y) const {
    return texel_of(d.geo->uv.at(x, y, 0), d.geo->uv.at(x, y, 1), w, h);
  }
  bool in_tile(long t) const { return !tile || (t >= t0 && t < t1); }
  // A pixel of texel t is one of this band's observations.
  bool keeps(long t) const { return !banded || (t >= 0 ? t >= k0 && t < k1 : first && !tile); }
  // ... and this band counts it (saturated, not finite, unlit) where it is left out.
  bool owns(long t) const { return !banded || (t >= 0 ? t >= o0 && t < o1 : first && first_tile); }
};

// The band of fit `opt` (--maps, --global, --tile).
UvBand uv_band(const FitOptions& opt);
// The usable pixels on the stride grid that the band keeps: the most records a view can give.
size_t usable_on_grid(const ViewData& d, int stride, const UvBand& band);
// View d's usable pixels on the stride grid that the band keeps, as records in *out (the others
// counted in *rep: a frame the buffers do not define, unlit); four at a time where `simd`
// (fit/records/pixel_frames.h line_lanes_on) and the view has one point light.
void add_pixel_observations(const ViewData& d, const ViewSpec& v, int stride, const UvBand& band,
                            bool simd, RecordSlot* out, FitReport* rep);

// The pixels of a geometry that views share (a fixed camera) which a load keeps: on the stride
// grid, in the rows it reads, on the mask with finite buffers, of a texel it keeps; in the order
// add_pixel_observations takes them, each with its texel, its frame and V from `eye`. Found once
// for every view of the geometry and eye, where each view found them again (the frames' square
// roots and divisions and the texels' lookups were a sixth of a band's load).
struct SharedPixels {
  Vec3 eye;
  std::vector<int> x, y;
  std::vector<long> t;
  // Per pixel, as arrays (kSharedRows of them, each `padded` long, the last pixel repeated to a
  // multiple of kSharedLanes): the position and the frame's axes U, W, N, x y z each; a view's
  // light reads them straight into its lanes (fit/records/pixel_frames.h shared_light_lanes), where
  // a pixel's record of them was copied into a quad first.
  static constexpr int kSharedRows = 12;
  size_t padded = 0;
  std::vector<double> frame;  // row k at frame[k * padded]
  std::vector<LocalDir> V;
  std::vector<uint8_t> ok;
  size_t bytes() const {  // what it holds
    return (x.capacity() + y.capacity()) * sizeof(int) + t.capacity() * sizeof(long) +
           frame.capacity() * sizeof(double) + V.capacity() * sizeof(LocalDir) + ok.capacity();
  }
};
// Views share their pixels where at least this many name one geometry (not a mesh) and each has
// one point light: SharedPixels' ~140 bytes a pixel are then at most 35 bytes a record (the
// records 56 bytes and more: BENCHMARKS.md's bound is 112); two views of a large sample would
// have held 1.3 times their records more.
constexpr size_t kShareFrom = 4;
// Whether view v, one of `views` naming its geometry, shares its pixels (lanes.shared_pixels and
// the four-pixel passes, line_lanes_on(lanes.simd), allowing).
bool shares_pixels(size_t views, const ViewSpec& v, const LineLanes& lanes);
// The most a shared pixel holds (its arrays grown by doubling), for the bands' plan.
constexpr size_t kSharedPixelBytes = 2 * (2 * sizeof(int) + sizeof(long)) +
                                     SharedPixels::kSharedRows * sizeof(double) + sizeof(LocalDir) +
                                     sizeof(uint8_t);
// Found for views that shares_pixels allows.
std::unique_ptr<const SharedPixels> shared_pixels(const ViewData& d, int stride,
                                                  const UvBand& band);
// A view's records from the pixels it shares (its geometry and eye those of `sp`, its rows
// those `sp` was found in, one point light): what usable_on_grid and add_pixel_observations give,
// the same records in the same order; the light eight pixels at a time where `avx512`
// (fit/records/pixel_frames.h shared_light_lanes).
size_t usable_shared(const ViewData& d, const SharedPixels& sp);
void add_shared_observations(const ViewData& d, const ViewSpec& v, const SharedPixels& sp,
                             const UvBand& band, bool avx512, RecordSlot* out, FitReport* rep);

}  // namespace aniso::fitting
