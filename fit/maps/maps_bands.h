// fit/ internal: --maps with --global, the texel rows fitted band by band
// (fit/maps/maps_bands.cpp).
#pragma once
#include <utility>
#include <vector>

#include "fit/maps/maps.h"
#include "fit/records/band_load.h"

namespace aniso::fitting {

// The rows of the maps (a --tile's, or all) in bands of about --maps-memory of records each:
// band j's load keeps the pixels of its rows and their --smooth reach, and its texels are fitted
// as a tile of those rows is (fit/maps/maps.h tile_rows: the same maps, byte for byte, as one
// band).
class MapsInBands {
 public:
  MapsInBands(const CaptureSet& set, const FitOptions& opt);
  int count() const { return static_cast<int>(rows_.size()); }
  size_t record_bytes() const { return bytes_; }  // of one load of every pixel (estimated)
  // Views with geometry of their own (not one fixed camera's): every band reads it again.
  size_t own_geometries() const { return own_geometries_; }
  // Band 0's observations (rep->maps_band_peak_bytes: what they hold).
  const ObsSet& load_first(FitReport* rep);
  // Every band's texels (band 0 loaded by load_first, the others loaded here, their counts and
  // load time added to *rep), joined into the maps of the options' rows.
  TexelMaps fit(const Core& global, const TexelMapOptions& to, FitReport* rep);
  double pixel_noise() { return loader_.pixel_noise(); }  // after fit

 private:
  std::vector<std::pair<int, int>> band_limits(const std::vector<double>& row_bytes,
                                               const std::vector<double>& shared_row_bytes,
                                               const FitOptions& opt) const;
  BandLoader loader_;
  TileRows all_;
  std::vector<TileRows> rows_;
  size_t bytes_ = 0, own_geometries_ = 0;
  std::shared_ptr<TexelScratch> scratch_ = texel_scratch();
};

}  // namespace aniso::fitting
