// --maps with --global in bands of texel rows (fit/maps/maps_bands.h): the records of one band at a
// time, in arrays whose pages are touched once; the maps the same as one band's.
#include "fit/maps/maps_bands.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "core/error.h"

namespace aniso::fitting {

// The bands' rows [row0, row1) over the rows of all_. Given the records' bytes by texel row, each
// band takes rows while its records, its --smooth reach's included, stay within --maps-memory (a
// row alone above it is a band of its own) and the pixels its views share within
// FitOptions::maps_shared_band_bytes: a sphere's uv crowds its pixels into some rows, where bands
// of equal rows exceed the budget (docs/solver-rules.md "Bands"). Without (a mesh traced per view),
// as many bands of equal rows as the whole estimate takes.
std::vector<std::pair<int, int>> MapsInBands::band_limits(
    const std::vector<double>& row_bytes, const std::vector<double>& shared_row_bytes,
    const FitOptions& opt) const {
  const int rows = all_.row1 - all_.row0;
  const double budget = opt.maps_memory_mb * 1e6;
  std::vector<std::pair<int, int>> out;
  if (row_bytes.size() != static_cast<size_t>(opt.maps_h)) {
    const double bands = std::ceil(static_cast<double>(bytes_) / budget);
    const int k = std::clamp(static_cast<int>(std::min(bands, 1e6)), 1, std::max(1, rows));
    for (int j = 0; j < k; ++j)
      out.emplace_back(all_.row0 + static_cast<int>(static_cast<long>(rows) * j / k),
                       all_.row0 + static_cast<int>(static_cast<long>(rows) * (j + 1) / k));
    return out;
  }
  // Prefix sums of the records' bytes and of the shared pixels'.
  std::vector<double> before(row_bytes.size() + 1, 0.0), shared(row_bytes.size() + 1, 0.0);
  for (size_t i = 0; i < row_bytes.size(); ++i) {
    before[i + 1] = before[i] + row_bytes[i];
    shared[i + 1] = shared[i] + (i < shared_row_bytes.size() ? shared_row_bytes[i] : 0.0);
  }
  auto fits = [&](int a, int b) {  // rows [a, b) and their reach within both budgets
    const TileRows r = rows_with_reach(a, b, opt);
    const auto b0 = static_cast<size_t>(r.band0), b1 = static_cast<size_t>(r.band1);
    return before[b1] - before[b0] <= budget &&
           shared[b1] - shared[b0] <= opt.maps_shared_band_bytes;
  };
  for (int a = all_.row0; a < all_.row1;) {
    int b = a + 1;
    while (b < all_.row1 && fits(a, b + 1)) ++b;
    out.emplace_back(a, b);
    a = b;
  }
  return out;
}

MapsInBands::MapsInBands(const CaptureSet& set, const FitOptions& opt)
    : loader_(set, opt), all_(tile_rows(opt)) {
  if (!(opt.maps_memory_mb > 0)) throw Error("fit: --maps-memory must be above 0 (MB)");
  bytes_ = loader_.record_bytes();
  const size_t geometries = geometry_views(set).size();
  own_geometries_ = geometries > 1 ? geometries : 0;
  const long w = opt.maps_w;
  std::vector<UvBand> plan;
  for (const auto& [row0, row1] :
       band_limits(loader_.row_bytes(), loader_.shared_row_bytes(), opt)) {
    const TileRows r = rows_with_reach(row0, row1, opt);
    rows_.push_back(r);
    UvBand b;
    b.w = opt.maps_w, b.h = opt.maps_h;
    b.banded = true;
    b.tile = opt.tile_count > 0;
    b.first_tile = opt.tile_index == 0;
    b.t0 = all_.band0 * w, b.t1 = all_.band1 * w;
    b.tile_o0 = all_.row0 * w, b.tile_o1 = all_.row1 * w;
    b.first = rows_.size() == 1;
    b.k0 = r.band0 * w, b.k1 = r.band1 * w;
    b.o0 = r.row0 * w, b.o1 = r.row1 * w;
    plan.push_back(b);
  }
  loader_.plan(std::move(plan));
}

namespace {

// The report keeps what the largest band held so far, and its shared pixels' part.
void keep_peak(const BandLoader& loader, FitReport* rep) {
  if (loader.held_bytes() <= rep->maps_band_peak_bytes) return;
  rep->maps_band_peak_bytes = loader.held_bytes();
  rep->maps_band_shared_bytes = loader.shared_bytes();
}

}  // namespace

const ObsSet& MapsInBands::load_first(FitReport* rep) {
  const ObsSet& os = loader_.load(0, rep);
  rep->maps_band_peak_bytes = 0;
  keep_peak(loader_, rep);
  return os;
}

TexelMaps MapsInBands::fit(const Core& global, const TexelMapOptions& to, FitReport* rep) {
  TexelMaps whole;
  for (int j = 0; j < count(); ++j) {
    if (j > 0) {
      const auto t0 = std::chrono::steady_clock::now();
      FitReport band_rep;
      loader_.load(static_cast<size_t>(j), &band_rep);
      add_counts(band_rep, rep);
      rep->observations += band_rep.observations;
      keep_peak(loader_, rep);
      rep->seconds_load +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    TexelMapOptions tb = to;
    tb.rows = rows_[static_cast<size_t>(j)];
    tb.scratch = scratch_.get();
    TexelMaps band = fit_texel_maps(loader_.observations(), global, tb);
    join_band(band, all_.row0, all_.row1, &whole);
    reuse_maps(scratch_.get(), std::move(band));
  }
  return whole;
}

}  // namespace aniso::fitting
