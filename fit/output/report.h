// fit/ output: the material file a fit writes (with its maps, sigmas and report), the tiles of a
// maps fit and their merge, and the fit as text for a person (fit/output/report.cpp,
// fit/output/report_text.cpp).
#pragma once
#include <string>
#include <vector>

#include "fit/types/fit_types.h"
#include "io/images/exr_compression.h"

namespace aniso {

// The plain names of the map files `write_fit` puts beside a material file when the result has
// maps (--maps) or a map of s (--topology-map). Each run writes them as one generation,
// STEM_KEY.GEN.exr (io/files/files.h write_generation), named by the material it writes last; they
// never replace a file.
std::vector<std::string> map_files(const std::string& material_path);

// The material file with "uncertainty", "fixed", "undetermined" and "report"; atomic.
// What write_fit writes for a result without maps, as text (fit --mpi sends rank 0's global fit).
std::string fit_text(const FitResult& r);
// The global fit of a file write_fit wrote (`text`, named `file` in messages; relative paths from
// `base_dir`): its material without maps (only the global values count), sigmas, report.
GivenGlobal given_global(const std::string& text, const std::string& file,
                         const std::string& base_dir);
// The same from a result in memory (a fit's own global fit before its maps): what given_global
// reads from fit_text(r), without the text (test FitMaps.APlainMapsFitTakesAtMostItsGlobalPixels:
// the maps bit for bit those of the two steps through a file).
GivenGlobal given_global_of(const FitResult& r, const std::string& file,
                            const std::string& base_dir);
// The maps' EXRs (and a map of s) compressed as `maps`.
void write_fit(const std::string& path, const FitResult& r,
               ExrCompression maps = ExrCompression::kZip);

// --tile: a self-describing tile of a maps fit (format "aniso-maps-tile": the tile, the grid, its
// rows, the global fit as write_fit writes it, and every texel's numbers, doubles written
// exactly), and `aniso merge`: tiles covering every row once, of one grid and one global fit,
// joined into the material and its maps: the same files as an untiled run, bit for bit.
void write_maps_tile(const std::string& path, const FitResult& r, const FitOptions& opt);
void merge_maps_tiles(const std::vector<std::string>& tiles, const std::string& out,
                      ExrCompression maps = ExrCompression::kZip);

// A table of every parameter against the truth (value, sigma, error, error/sigma). Also returns
// the worst relative errors through the optional pointers (for tests).
struct TruthErrors {
  double kd_rel = 0, ks_rel = 0, n_rel = 0, psi_deg = 0;
  double kd_sigmas = 0, ks_sigmas = 0, n_sigmas = 0, psi_sigmas = 0;  // worst |error| / sigma
  double topo_abs = 0, topo_sigmas = 0;  // fiber model: |s - s_true| or |A - A_true|
};
// Every fitted value with its sigma ("undetermined" where the data cannot fix it): printed by
// `aniso fit` every time, with or without a truth.
std::string describe_fit(const FitResult& r);

std::string compare_to_truth(const FitResult& r, const Material& truth, TruthErrors* errors);

// The maps of a --maps fit against the truth at every determined texel's centre (the truth's own
// maps sampled there, or its one value): per parameter the median and 90th percentile of the
// error (percent; degrees for the fiber angle) and the median error in sigmas.
std::string compare_maps_to_truth(const FitResult& r, const Material& truth);

}  // namespace aniso
