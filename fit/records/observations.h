// fit/ internal: what the solver sees of a capture set or a sample table. One observation per
// pixel (three channels) with its lights already reduced to local directions and irradiance
// scales (exposure folded in); lights below the horizon are dropped here, they contribute exactly
// zero. Not installed for other folders: fit.h is the public face.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/frame.h"
#include "core/local_dir.h"
#include "fit/types/fit_types.h"
#include "io/formats/capture.h"
#include "models/material.h"

namespace aniso::fitting {

// A record holds everything in float: directions (a unit direction to float's 6e-8; the lobe's
// x^n moves by n times that, 6e-5 relative at n = 1000, far below any image's noise, and the
// models read them as double), values from images, irradiance: 32 + 24 bytes per pixel and light,
// half the 14-double record BENCHMARKS.md counts the memory against (they were 72 + 40 with the
// directions in double, 60 + 24 with the texture coordinates in every record, and 52 + 24 with
// an ambient part that was always 0 and the fiber model's topology in every record).
struct LocalDirF {
  float u = 0, w = 0, n = 1;
  LocalDirF() = default;
  LocalDirF(const LocalDir& d)  // NOLINT: a record takes a direction as it is computed
      : u(static_cast<float>(d.u)), w(static_cast<float>(d.w)), n(static_cast<float>(d.n)) {}
  operator LocalDir() const { return {u, w, n}; }  // NOLINT: the models read double
};
struct ObsLight {
  LocalDirF L;
  float E[3];  // irradiance times exposure, per channel
};
// The ambient term k_a I_a is not fitted and k_a is taken as 0 (docs/models.md: a known constant
// part would be exposure k_a I_a per view), so a value is the lights' sum alone.
struct Observation {
  LocalDirF V;
  uint32_t first_light = 0, num_lights = 0;
  float y[3];  // measured value
};
static_assert(sizeof(ObsLight) == 24 && sizeof(Observation) == 32, "records as counted above");
// How the fiber model's topology enters: one s for the whole sample, the map amplitude A on top
// of per-pixel s_math and map values, s_math alone (nothing to fit), or a map of s over uv.
enum class TopologyMode { kGlobalS, kAmplitude, kMathematical, kTexels };
// Pages of anonymous memory, mapped without reserving them (a page costs only once written):
// what a record array of kMappedBytes or more is allocated in.
inline constexpr size_t kMappedBytes = size_t{32} << 20;
void* map_pages(size_t bytes);  // throws std::bad_alloc where the mapping fails
void unmap_pages(void* p, size_t bytes);

// std::allocator, except that resize() leaves new records unwritten: the loader grows the arrays
// by a batch of views and the views' threads write their records in place. A large array is
// mapped pages: reserved room costs nothing until written, so the loader of bands
// (fit/records/band_load.h) reserves the whole set's room once and every band writes over the pages
// the band before it touched, instead of a bigger band moving the arrays to fresh pages.
template <class T>
struct RecordAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = RecordAllocator<U>;
  };
  RecordAllocator() = default;
  template <class U>
  RecordAllocator(const RecordAllocator<U>&) noexcept {}
  T* allocate(size_t n) {
    if (n * sizeof(T) < kMappedBytes) return std::allocator<T>::allocate(n);
    return static_cast<T*>(map_pages(n * sizeof(T)));
  }
  void deallocate(T* p, size_t n) {
    if (n * sizeof(T) < kMappedBytes)
      std::allocator<T>::deallocate(p, n);
    else
      unmap_pages(p, n * sizeof(T));
  }
  template <class U>
  void construct(U*) noexcept {}
  template <class U, class... A>
  void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
};
struct ObsSet {
  std::vector<Observation, RecordAllocator<Observation>> obs;
  std::vector<ObsLight, RecordAllocator<ObsLight>> lights;
  // Texture coordinates u, v of obs[i] at uv[2i], uv[2i + 1]: only where a fit reads them
  // (--topology-map); empty otherwise.
  std::vector<float, RecordAllocator<float>> uv;
  // --maps: the texel of obs[i] on the maps' grid (texel_of in fit/maps/maps.h; kNoTexel outside
  // [0, 1)^2), found once while loading: 4 bytes an observation to fault in where its u, v took 8,
  // and no pass over them to bin. Empty without --maps.
  static constexpr uint32_t kNoTexel = UINT32_MAX;
  std::vector<uint32_t, RecordAllocator<uint32_t>> texel;
  // The fiber model's mathematical topology s_math and topology-map value m of obs[i] at
  // topo[2i], topo[2i + 1]: only where the set has a topology buffer or map (kAmplitude,
  // kMathematical); empty otherwise, where both are 0.
  std::vector<float, RecordAllocator<float>> topo;
  float smath(size_t i) const { return topo.empty() ? 0.f : topo[2 * i]; }
  float mapv(size_t i) const { return topo.empty() ? 0.f : topo[2 * i + 1]; }
  TopologyMode topology = TopologyMode::kGlobalS;
  int texels = 0;            // kTexels: an N x N map of s over uv
  std::string topology_map;  // recorded in the result
  MathTopology topology_mathematical = MathTopology::kNone;
  bool grey = false;  // a grey table: the three channels repeat one value
  // The line model's passes over these records take four pixels at a time (FitOptions::line_lanes
  // .simd, on a CPU with AVX2 and FMA: line_lanes_on in fit/records/pixel_frames.h).
  bool simd = true;
  // Where each view's lights begin in `lights`, in view order (a view's observations name lights
  // of their own view only): which view an observation is of, for the uncertainty that errors
  // shared by a view's pixels add (fit/global/view_sandwich.h). Empty for tables.
  std::vector<size_t> view_lights;
  // The capture came from a photo shoot (aniso import): its calibration and lamps are measured.
  bool from_shoot = false;
  // Noise of the images themselves, from differences of neighbouring pixels (robust, so edges
  // and the smooth shading between neighbours hardly count); 0 where there are no images.
  double pixel_noise = 0;
};

ObsSet capture_observations(const CaptureSet& set, const FitOptions& opt, FitReport* rep);
// The bytes os's records hold (observations, lights, and the per-observation uv, texel and
// topology arrays), as --maps-memory counts them.
size_t held_bytes(const ObsSet& os);
// The loader's pixel counts of `from` (pixels, and those left out, by reason) added to *to.
void add_counts(const FitReport& from, FitReport* to);
// A table's rows; with --maps and u, v columns, each row's texel.
ObsSet table_observations(const SampleTable& table, const FitOptions& opt, FitReport* rep);

// Up to `count` of n observation indices, spread by the golden-ratio sequence rather than a
// fixed stride: a stride can alias with the layout of the data (10 000 identical views, a
// stride equal to the view size, gave two distinct pixels and psi 131 deg for 30).
std::vector<size_t> start_subset(size_t n, size_t count);

// f(x, y, frame) for every usable pixel of a loaded view whose geometry gives a shading frame, in
// row order.
template <class F>
void for_each_framed_pixel(const ViewData& d, F&& f) {
  const ViewGeometry& g = *d.geo;
  const int w = d.rgb.width, h = d.rgb.height;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      SurfacePoint sp;
      if (d.usable(static_cast<size_t>(y) * w + x) && frame_at(g.P, g.N, g.U, x, y, &sp))
        f(x, y, sp);
    }
}

double median_abs(std::vector<double> v);

}  // namespace aniso::fitting
