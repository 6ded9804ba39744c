// fit/ internal: the loader of a capture's views (fit/records/observations.cpp) and what it shares
// with the loader of bands (fit/records/band_load.cpp).
#pragma once
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "fit/records/observations.h"
#include "fit/records/pixel_records.h"
#include "io/formats/capture.h"
#include "io/images/image_io.h"

namespace aniso::fitting {

// What lives from one load of views to the next: one for a plain load; with bands, one for all
// of them (fit/maps/maps_bands.cpp), so that a fixed camera's geometry is decoded once, the file
// buffers and decoded images are reused, and the records' arrays keep their pages.
struct LoadState {
  GeometryCache geometry;  // a fixed camera's buffers decoded once, shared by every view
  // File buffers and decoded images reused view after view, until the last view is loaded.
  std::unique_ptr<ExrReadBuffers> read_buffers = std::make_unique<ExrReadBuffers>();
  std::vector<float> diffs;  // float: these are differences of float pixels
  TopologyMap map;
  bool map_loaded = false;
  // Bands: the plan and, per geometry (by its key, io/formats/capture.h geometry_key), the rows
  // each band reads, found from the whole geometry by the first band and kept for the others: a
  // view whose geometry no other view shares reads only those rows of it in every later band.
  std::vector<UvBand> bands;
  struct GeoRows {
    std::vector<std::vector<uint8_t>> rows;  // per band: 1 for a row with a pixel it keeps
    std::vector<int> first;                  // per row: the first band to read it (-1: none)
    size_t outside = 0;  // pixels on the stride grid outside --tile's texels (a frame defined)
  };
  std::mutex geo_mutex;
  std::map<std::string, std::unique_ptr<GeoRows>> geo_rows;
  // Without bands, subsampled: per geometry, the rows of the stride grid and of the noise
  // estimate (add_neighbour_differences) that hold a mask pixel: the only rows read.
  std::map<std::string, std::unique_ptr<std::vector<uint8_t>>> grid_rows;
  std::map<std::string, GeometryViews> geometries;  // by geometry key
  size_t band = 0;                                  // the band being loaded
  // The room reserved once for every band (mapped pages: only what a band writes is touched):
  // records and lights of one load of every pixel, as estimated (BandLoader::record_bytes).
  size_t reserve_obs = 0, reserve_lights = 0;
  // Views' pixel states (ViewData::use) given back, for the views after them.
  std::mutex use_mutex;
  std::vector<std::vector<uint8_t>> spare_use;
  // The pixels that views sharing a geometry share in the load being made, by geometry key (null:
  // they do not apply); found by the first of its views, let go at the end of the load.
  std::mutex shared_mutex;
  std::map<std::string, std::unique_ptr<const SharedPixels>> shared;
  size_t shared_bytes = 0;  // what they held, all of them, in the last load
};

// The fiber model's topology from what the set carries: a map means its amplitude is fitted over
// the per-pixel mathematical topology (0 where no buffer); a topology buffer alone fixes s; else
// one s (or, with --topology-map N, an N x N map of s over uv).
void choose_topology(const CaptureSet& set, const FitOptions& opt, ObsSet* os);
// sigma of one pixel: the robust sigma of the differences a - 2b + c, over sqrt(1 + 4 + 1); 0
// without any.
double pixel_noise(std::vector<float>* diffs);
// The views' records into *os (its arrays emptied first, their allocations kept): every pixel
// (no bands), or band st->band of st->bands. The report's counts are added to *rep.
void load_views(const CaptureSet& set, const FitOptions& opt, LoadState* st, ObsSet* os,
                FitReport* rep);

// Bands (fit/records/band_load.cpp): the rows each band reads of the geometry with key `key`, found
// once from `geo` (whole: the first band's) and kept (views sharing one share them); null where not
// found yet and geo is null. And, of a band's rows (or of every row without bands), the pixels on
// the stride grid it owns that are left out (saturated, not finite), counted.
const LoadState::GeoRows* rows_of(LoadState* st, const std::string& key, const ViewGeometry* geo,
                                  int stride);
void count_left_out(const ViewData& d, const UvBand& band, int stride, FitReport* rep);

}  // namespace aniso::fitting
