// fit/ internal: a view's pixels to records (fit/observations.cpp's loader): where they go, the
// tile's band of texels, and each usable pixel's frame, V and lights in it.
#pragma once
#include <cstddef>
#include <cstdint>

#include "fit/maps.h"
#include "fit/observations.h"
#include "io/capture.h"

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
};

// --maps: the w x h grid of the maps (w = 0 without), and with --global and --tile the texels
// [t0, t1) whose observations the tile keeps (its rows and its --smooth band); every pixel where
// the band is off.
struct UvBand {
  bool on = false;
  int w = 0, h = 0;
  long t0 = 0, t1 = 0;
  long texel(const ViewData& d, int x, int y) const {
    return texel_of(d.geo->uv.at(x, y, 0), d.geo->uv.at(x, y, 1), w, h);
  }
  bool keeps(long t) const { return !on || (t >= t0 && t < t1); }
  bool keeps(const ViewData& d, int x, int y) const { return !on || keeps(texel(d, x, y)); }
};

// The band of fit `opt` (--maps, --global, --tile).
UvBand uv_band(const FitOptions& opt);
// The usable pixels on the stride grid (in the tile's band): the most records a view can give.
size_t usable_on_grid(const ViewData& d, int stride, const UvBand& band);
// View d's usable pixels on the stride grid in its band, as records in *out (the others counted
// in *rep: outside the tile, a frame the buffers do not define, unlit).
void add_pixel_observations(const ViewData& d, const ViewSpec& v, int stride, const UvBand& band,
                            RecordSlot* out, FitReport* rep);

}  // namespace aniso::fitting
