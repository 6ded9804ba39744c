// fit/ types: what a fit is asked (FitOptions) and what it answers (FitResult: the material,
// sigmas, maps, report): the floor every other part of fit/ stands on (ARCHITECTURE.md).
#pragma once
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "io/formats/capture.h"
#include "io/formats/table.h"
#include "io/images/exr_compression.h"
#include "models/material.h"

namespace aniso {

class ProgressSink;  // core/progress.h

// --model: one of the two models, or both with the lower BIC kept.
enum class FitModel { kLine, kFiber, kAuto };
// --loss: the robust loss of the final solve, scaled to 3 robust sigmas of the residuals.
enum class FitLoss { kHuber, kCauchy, kNone };
// --psi-from-symmetry: when the fiber direction is placed again by the highlight's symmetry alone
// (fit/global/psi_symmetry.h): where the line model misses the data (auto), always, or never.
enum class PsiSymmetry { kAuto, kAlways, kNever };
enum class LampsFromHighlight { kAuto, kAlways, kNever };
const char* psi_symmetry_name(PsiSymmetry p);
const char* fit_model_name(FitModel m);
const char* fit_loss_name(FitLoss l);

// The fiber model's quadrature error per value at each order its global fit tried (against order
// 16, at its start; fit/global/fiber_order.h) and the images' noise it was held against. Each texel
// of
// --maps takes from it the smallest order whose error stays under the same 1 % of noise /
// sqrt(values) for its own values (about 38 times the global fit's allowance for a texel of 700
// values in a set of a million): the global fit's order, or lower. Stored with the fit (report
// fiber_order_errors), so tiles and --global runs choose as the plain run does.
struct FiberOrderErrors {
  static constexpr int kMaxOrder = 16;  // the highest quadrature order (the reference)
  static constexpr int kMaxOrders = 8;
  static constexpr double kShare = 0.01;  // of noise / sqrt(values): the largest shift, in sigma
  int count = 0;                          // 0: unknown (every texel at the global fit's order)
  int order[kMaxOrders] = {};
  double rms[kMaxOrders] = {};  // ascending orders
  double noise = 0;
  // The error per value that `values` values allow at this noise.
  double allowed(double values) const { return kShare * noise / std::sqrt(values); }
  // The order for `values` values: the smallest listed under the allowance, at most `cap`.
  int order_for(double values, int cap) const {
    if (count == 0 || !(noise > 0) || !(values > 0)) return cap;
    for (int k = 0; k < count && order[k] < cap; ++k)
      if (rms[k] <= allowed(values)) return order[k];
    return cap;
  }
};

// A global fit given to --maps (--global, or rank 0's under `fit --mpi`): what an earlier fit's
// file says, read by given_global.
// What a warning is about: what a later phase, or a fit that reads this one's file back (a
// --global, the tiles' merge), picks warnings out by, never by their words. The material file
// records it beside the texts (report.warnings_about, one name per warning).
enum class WarningAbout {
  kOther,
  kGlobalMisfit,   // the one parameter set does not describe the data
  kMaps,           // counts over the --maps grid (a reader counts its own)
  kTile,           // which rows a --tile fit holds
  kFiberAngle,     // the fiber direction is not determined (another minimum fits as well)
  kSolverStopped,  // the solver ran out of iterations
};
const char* warning_about_name(WarningAbout about);  // "other", "global_misfit", "maps", ...
// A name read back ("other" for one it does not know). A file without report.warnings_about
// (written before it was recorded): from the words each kind's warnings began with then.
WarningAbout warning_about_named(const std::string& name);
WarningAbout warning_about_from_words(const std::string& text);

// A warning: said plainly to the user and recorded in the file, with what it is about.
struct Warning {
  std::string text;
  WarningAbout about = WarningAbout::kOther;
  Warning(std::string t, WarningAbout a = WarningAbout::kOther) : text(std::move(t)), about(a) {}
  Warning(const char* t, WarningAbout a = WarningAbout::kOther) : text(t), about(a) {}
  operator const std::string&() const { return text; }
};

// A lamp of a capture as the sample's highlight placed it (fit/lamps/highlight_lamps.h), as the
// capture gave it and as found (report.lamps_from_highlight.lamps).
struct LampPlaced {
  size_t view = 0, light = 0;
  double given[3] = {}, prior_sigma_m[3] = {}, found[3] = {}, sigma_m[3] = {};
  bool stated = false;  // the capture stated the prior's sigma
  double moved_sigmas = 0;
  bool released = false;  // moved past 5 of its sigmas: solved again with its prior widened
  size_t pixels = 0;
};

struct GivenGlobal {
  std::string file;  // where it came from, for messages and the report
  Material material;
  std::map<std::string, std::vector<double>> sigma;  // as its file recorded them
  int fiber_order = 0;                  // the quadrature order its fit chose (report.fiber_order)
  FiberOrderErrors fiber_order_errors;  // report.fiber_order_errors (absent: count 0)
  double implausible_limit = 0;         // report.implausible_limit (0: compute it here, as before)
  // Its report's views, residual RMS and warnings (carried into this result's report).
  size_t views = 0;
  double rms = 0;
  std::vector<Warning> warnings;
  std::string capture_layout;  // report.capture_layout ("" in older files)
  // The lamps its fit was made under where the highlight placed them (report.lamps_from_highlight
  // used): the fit with it is made under them too.
  std::vector<LampPlaced> lamps_placed;
};

// --maps-iterations' default: the iterations each texel's solver (LM or Ceres) may take.
constexpr int kTexelIterations = 100;

// --maps with --global in bands: views that share a geometry (a fixed camera) each read its pixels
// (fit/records/pixel_records.h SharedPixels: position and frame, ~150 bytes a pixel), so a band
// holds at most this many bytes of them, which then stay in the last-level cache from view to view
// (read from memory once a view, they made the band's load memory-bound: BENCHMARKS.md, "Maps").
inline constexpr double kMapsSharedBandBytes = 4e6;
// A plain --maps fit whose records pass --maps-memory fits its global values first on a
// --subsample (fit/fit.cpp global_subsample_for) of at most this many pixels: they only start
// the texels and fill those the data do not determine, so more pixels there cost time and change
// the maps by thousandths of a sigma (BENCHMARKS.md, "Maps").
inline constexpr double kMapsGlobalPixels = 1e6;
// The global fit's robust stage on a set of at least kMinStagedStride x kStagedPixels pixels runs
// first on every k-th pixel (k = pixels / kStagedPixels, at most kStagedStride), then on every
// pixel from the point it reached: the same minimum (the solver's own stopping rule, on every
// pixel, decides where it ends), in a few passes over every pixel instead of one per iteration.
// Below kMinStagedStride the iterations on the subsample cost about what they save.
inline constexpr double kStagedPixels = 1e6;
inline constexpr int kStagedStride = 16, kMinStagedStride = 4;

// Which of the equal forms of the line model's passes run; the widest the CPU has by default, the
// others for the tests that hold them to one another (bit for bit, or to the sums' rounding).
struct LineLanes {
  bool simd = true;           // four pixels at a time (AVX2 and FMA) where the CPU has them
  bool shared_pixels = true;  // views of one geometry and eye share their pixels' frames (simd)
  bool avx512 = true;         // the shared pixels' light eight at a time where the CPU has AVX-512F
};

struct FitOptions {
  FitModel model = FitModel::kLine;
  bool fit_isotropic = false;
  bool fit_second = false;
  // --keep-anisotropic: where an isotropic model fits the data better by BIC, keep the fitted
  // anisotropic material (its fiber direction undetermined) instead of writing the isotropic one.
  bool keep_anisotropic = false;
  // A photo shoot's point lamps placed again by the sample's highlight, each position fitted
  // together with the line model's material (fit/lamps/highlight_lamps.h), then the fit asked for
  // made under the lamps found: by default where the capture states its lamps' sigma (an imported
  // shoot) and the fit can (auto), or always (--lamps-from-highlight), or never
  // (--lamps-as-imported).
  LampsFromHighlight lamps_from_highlight = LampsFromHighlight::kAuto;
  // The global fit's comparison with the isotropic part alone: off for the global fit a --maps
  // fit starts its texels from (every texel is fitted with the anisotropic model).
  bool test_isotropic = true;
  int subsample = 1;  // use every k-th pixel in x and y
  int max_iterations = 200;
  int threads = 2;  // every phase of the fit: loading, solving, the maps' texels
  FitLoss loss = FitLoss::kHuber;
  const ProgressSink* progress = nullptr;  // core/progress.h; null: silent
  // How the maps' EXRs are written (fit/output/report.h write_fit): not what the fit computes.
  ExrCompression maps_compression = ExrCompression::kZip;
  // fiber model: Gauss-Legendre order per specular panel (0: chosen from the noise,
  // fit/global/fiber_order.h)
  int fiber_order = 0;
  // Line model without optional terms: 256 pixels per residual block with analytic derivatives
  // and the robust loss by reweighting (false: one autodiff block per pixel with Ceres' loss).
  bool chunked = true;
  int topology_texels = 0;  // fiber model: fit an N x N map of s over uv (0 = one s)
  // Covariance by Ceres' dense SVD of the whole Jacobian (the reference) instead of the normal
  // equations accumulated in one pass (fit/global/uncertainty.cpp).
  bool ceres_covariance = false;
  // --solver ceres: the plain line model's global fit by Ceres (the fitter of record, IRLS over
  // 256-pixel blocks) instead of the fused Levenberg-Marquardt (fit/solvers/line_solve.h; the tests
  // compare the two).
  bool ceres_solver = false;
  // --maps WxH (line model): after the global fit, per-texel maps of k_d, k_s, n and psi over the
  // sample's texture coordinates (0 = none).
  int maps_w = 0, maps_h = 0;
  // --tile i/N: fit only texel rows [i*H/N, (i+1)*H/N) of the maps (tile_count 0 = all).
  int tile_index = 0, tile_count = 0;
  // --maps-solver ceres: every texel by Ceres (the fitter of record) instead of the hand-written
  // Levenberg-Marquardt (same function, bounds and start; the tests compare the two).
  bool maps_ceres = false;
  // --smooth lambda / --smooth-sweeps K: couple each texel to its 4 neighbours (fit/maps/maps.h).
  double maps_smooth = 0;
  int maps_sweeps = 10;
  int maps_iterations = kTexelIterations;  // --maps-iterations: each texel's solver
  // --maps-lanes: the line model's texel passes eight floats a register (AVX2) or sixteen
  // (AVX-512, refused on a CPU without it); 0: the widest this CPU has. The maps of the two
  // widths agree to float's rounding (~1e-3 sigma), not bit for bit.
  int maps_lanes = 0;
  // --maps-memory MB: with --global, the records held at once; the texel rows are fitted in as
  // many bands as that takes (fit/records/band_load.h), each reading only its rows of the views.
  double maps_memory_mb = 512;
  // ... and at most this many bytes of the pixels views share a band (kMapsSharedBandBytes; the
  // tests lower it).
  double maps_shared_band_bytes = kMapsSharedBandBytes;
  // Without --global, past --maps-memory: the global fit's most pixels (kMapsGlobalPixels; the
  // tests lower it).
  double maps_global_pixels = kMapsGlobalPixels;
  // The robust stage's subsample first, on every (pixels / this)-th pixel (kStagedPixels; 0:
  // never; the tests lower it).
  double staged_pixels = kStagedPixels;
  // --global MATERIAL: the global fit (every texel's start, and the values of the texels the data
  // do not determine) taken from an earlier fit instead of fitted here. With --tile, the tile then
  // keeps only the observations whose uv falls in its rows (and its --smooth band): a tile's
  // memory is its share of the sample, not the whole set.
  std::optional<GivenGlobal> global;
  LineLanes line_lanes;
  PsiSymmetry psi_symmetry = PsiSymmetry::kAuto;
  // The line model's fiber angle held at this (degrees) instead of fitted, with every other
  // number fitted under it by Ceres; its sigma is the caller's. Unset: fitted.
  std::optional<double> hold_psi_deg;
};

// --maps: every texel's fit (row-major, glTF uv: texel (i, j) covers u in [i/W, (i+1)/W)). Texels
// the data do not determine hold the global fit's values with sigma = the prior's spread (the
// width of the parameter's bounds / sqrt 12) and determined = 0.
struct TexelMaps {
  int w = 0, h = 0;
  std::vector<double> kd, ks;      // 3 per texel
  std::vector<double> n, psi_deg;  // 1 per texel
  std::vector<double> kd_sigma, ks_sigma, n_sigma, psi_sigma_deg;
  std::vector<double> s, s_sigma;  // the fiber model's topology s per texel (else empty)
  // What `s` holds: "s", or "amplitude": a topology map's amplitude A per texel (docs/formats.md
  // "Material maps": maps.s or maps.amplitude).
  std::string s_key = "s";
  // The RMS of a solved texel's residuals (image units, every channel's value): against the
  // images' noise, how well the model describes the texel; -1 where no problem was solved.
  std::vector<double> residual;
  std::vector<int> pixels;          // observations (pixels) per texel
  std::vector<uint8_t> determined;  // 1 = fitted and determined by its data
  // The texel rows this result holds (a tile: a band of rows): every per-texel array above holds
  // these rows only, from texel row0 * w on.
  int row0 = 0, row1 = 0;
  double smooth = 0;  // --smooth lambda (0: every texel alone)
  int sweeps = 0;     // its Jacobi sweeps
  size_t fitted = 0;  // texels with a problem solved
  // of those, texels whose solver stopped at --maps-iterations (marked undetermined)
  size_t not_converged = 0;
  double rms = 0;                 // residual RMS over the solved texels' observations
  double sum_sq = 0, values = 0;  // its sum of squares and count (bands of rows add up)
  double seconds = 0;
  int threads = 0;  // the threads its texels were solved on (--threads)
  int lanes = 0;    // the float lanes of its line-model texels (16, 8; 0: none in float)
  // The fiber model's texels solved at each quadrature order (index: the order; FiberOrderErrors).
  size_t texels_by_order[FiberOrderErrors::kMaxOrder + 1] = {};
};

// The per-texel arrays of a TexelMaps (per-texel count `k`), as tiles name them.
struct TexelArray {
  const char* key;
  int k;
  std::vector<double> TexelMaps::*d;
};
inline const TexelArray kTexelArrays[] = {{"kd", 3, &TexelMaps::kd},
                                          {"ks", 3, &TexelMaps::ks},
                                          {"n", 1, &TexelMaps::n},
                                          {"psi_deg", 1, &TexelMaps::psi_deg},
                                          {"kd_sigma", 3, &TexelMaps::kd_sigma},
                                          {"ks_sigma", 3, &TexelMaps::ks_sigma},
                                          {"n_sigma", 1, &TexelMaps::n_sigma},
                                          {"psi_sigma_deg", 1, &TexelMaps::psi_sigma_deg},
                                          {"s", 1, &TexelMaps::s},  // the fiber model's (or empty)
                                          {"s_sigma", 1, &TexelMaps::s_sigma},
                                          {"residual", 1, &TexelMaps::residual}};

struct FitReport {
  // What the fit read and how: the capture's files (capture_fingerprint), its views' cameras and
  // poses (capture_layout) and the options (options_fingerprint). A --global material must share
  // the layout (its pixels may have been edited since); the tiles of one merge share all three.
  // Empty when not known.
  std::string capture_fingerprint, capture_layout, options_fingerprint;
  size_t views = 0, pixels = 0, observations = 0;  // observations = pixels x channels
  size_t masked_out = 0, saturated = 0, nonfinite = 0, unlit = 0;
  size_t implausible = 0;  // values above 1e4 x the 90th percentile: left out
  // That limit (0: too few pixels to set one); a --global fit's is used by the maps after it, so
  // tiles, which hold only their rows, leave out exactly what one run over all rows would.
  double implausible_limit = 0;
  size_t outside_tile = 0;  // --global with --tile: pixels whose uv falls in another tile's rows
  // --maps with --global: the bands of texel rows it was fitted in (--maps-memory), and the
  // records' bytes one load of every pixel would have held (estimated from view 0's mask).
  int maps_bands = 0;
  size_t maps_record_bytes = 0;
  // What the largest band held: its records (held_bytes) and its views' shared pixels.
  size_t maps_band_peak_bytes = 0;
  size_t maps_band_shared_bytes = 0;  // ... of it the shared pixels
  // --maps: determined texels whose residual RMS is over twice the images' noise (fit.cpp).
  size_t maps_misfit_texels = 0;
  double maps_memory_mb = 0;       // --maps-memory
  size_t maps_own_geometries = 0;  // views with geometry of their own, read again by every band
  // --maps without --global whose records would pass --maps-memory: the global fit ran first on
  // every k-th pixel in x and y (this k, with --subsample's), the maps then band by band (0: not).
  int global_subsample = 0;
  int iterations = 0;
  // The solver's cost at its start and after each accepted step (Ceres: each iteration, the
  // rounds of a reweighted loss one after another): how it converged.
  std::vector<double> convergence;
  // The robust stage's first part on every k-th pixel (kStagedPixels): this k (0: none) and its
  // iterations there (`iterations` counts those on every pixel).
  int staged_stride = 0, staged_iterations = 0;
  double seconds = 0, seconds_load = 0, seconds_start = 0, seconds_solve = 0,
         seconds_covariance = 0;
  double rms = 0, noise_sigma = 0, loss_scale = 0;
  double pixel_noise = 0;  // of the images, from neighbouring pixels (0 for tables)
  std::string termination, loss;
  // CONVERGENCE by the crawl rule (fit/solvers/crawl.h): the cost still fell, by a steady ratio,
  // with under kCrawlLeftChi2 left to gain.
  bool stopped_on_crawl = false;
  std::string covariance;  // how the uncertainty was computed
  std::string solver;      // which solver found the minimum ("fused LM" or "ceres")
  // The fused solver's pass: four pixels at a time (AVX2 and FMA, chosen at run time) or one; the
  // two agree to ~1e-6 sigma, so a fit is reproduced exactly on a machine with the same pass.
  std::string pass;
  size_t residual_evaluations = 0, jacobian_evaluations = 0;
  std::string start;                    // the grid node the solve started from
  std::string global_from;              // --global: the material the global fit was taken from
  int fiber_order = 0;                  // the fiber model's quadrature order (0: the line model)
  FiberOrderErrors fiber_order_errors;  // what its texels chose their orders from
  double rss = 0, bic = 0;
  size_t parameters = 0;
  std::string model_selection;  // --model auto: the comparison and why
  // The fitted material against the isotropic part alone, by BIC on the same values
  // (fit/global/isotropic_alternative.h); tested false where the fit had no such test.
  struct AnisotropyTest {
    bool tested = false;
    size_t values = 0;  // observations x channels compared
    double bic_anisotropic = 0, bic_isotropic = 0;
    // Where the isotropic part beat the fitted material: the line model with the isotropic part
    // (both lobes), whose BIC tells whether an anisotropic lobe is there at all.
    bool with_both_tested = false;
    double bic_with_both = 0;
    // What the better model with a lobe draws of the signal's energy beyond the isotropic part.
    double lobe_share = -HUGE_VAL;
    bool isotropic_preferred = false;
    bool isotropic_written = false;  // the material written is the isotropic one
    double iso_kd[3] = {0, 0, 0}, iso_ks[3] = {0, 0, 0}, iso_n = 0;  // its fit on `values`
  } anisotropy;
  // Said plainly to the user and recorded in the file: a fit that may be wrong (the model does
  // not describe the data, ...), with the likely cause and what it is about.
  std::vector<Warning> warnings;
  // Said and recorded, but not trouble: what a person should know of the result (texels that lie
  // outside the sample).
  std::vector<std::string> notes;
  std::vector<std::string> model_summaries;  // --model auto: one line per model
  using LampPlaced = aniso::LampPlaced;
  struct LampsFromHighlight {
    bool asked = false;
    bool by_default = false;  // not asked for: the default for an imported shoot's capture
    std::string from_global;  // placed with the global fit of this --global file, not here
    // The fit was made under the lamps found; where not, `skipped` says why (the fit is then made
    // under the lamps as given).
    bool used = false;
    std::string skipped;
    std::vector<LampPlaced> lamps;
    size_t pixels = 0, views_left_out = 0;
    double pixel_sigma = 0, seconds = 0;
    int iterations = 0;
    // The jackknife over views of the joint problem (k_d, k_s, n, psi in degrees), and its views.
    std::vector<double> jackknife_sigma;
    size_t jackknife_views = 0;
    double lamp_sigma_scale = 1;  // the lamps' sigma over what the problem alone says of them
  } lamps_from_highlight;
  // The fiber direction from the highlight's symmetry alone (fit/global/psi_symmetry.h): whether
  // it ran (`ran`; `why` says why not, or why it ran), what it found, and whether the material's
  // psi is it (`used`: the other numbers then fitted under it; `why_not` where not).
  struct PsiFromSymmetry {
    bool ran = false, used = false;
    std::string mode, why, why_not;
    double psi_deg = 0, sigma_deg = 0;  // the symmetry's
    double model_psi_deg = 0,
           model_sigma_deg = -1;  // the line model's own (sigma -1: undetermined)
    double relative_rms = 0, seconds = 0;
    size_t views = 0, pixels = 0;
    std::vector<double> jackknife_psi_deg;
  } psi_from_symmetry;
  // A measured file's fit: relative RMS of the material against its readings, and per viewer
  // angle (degrees) of the file's grid.
  double measured_rel_rms = -1, measured_median_rel = -1;
  std::vector<std::pair<double, double>> measured_rel_rms_by_angle;
};

struct FitResult {
  Material material;
  // One standard deviation per fitted number, keyed like the material file (kd, ks, n,
  // fiber_angle_deg, isotropic.kd, ...); absent when undetermined.
  std::map<std::string, std::vector<double>> sigma;
  // What the images' noise alone gives (same keys): `sigma` is the whole uncertainty, the larger
  // of this and the spread the views' residuals show (fit/global/view_sandwich.h) where the capture
  // came from a photo shoot or the model misses the data; and how `sigma` was found.
  std::map<std::string, std::vector<double>> sigma_noise_only;
  std::string uncertainty_basis;
  std::map<std::string, std::string> fixed;         // not fitted, and why
  std::map<std::string, std::string> undetermined;  // fitted but not determined by the data
  FitReport report;
  // The full correlation matrix of the fitted numbers (kd.r ... ks.b, fiber_angle, log n, ...),
  // row-major, with the parameter names; empty when the covariance is not available.
  std::vector<std::string> correlation_names;
  std::vector<std::vector<double>> correlation;
  // --topology-map N: the N x N texels of s (row-major, glTF uv) and their sigmas (-1:
  // undetermined).
  TexelMaps maps;  // --maps
  int s_texels_n = 0;
  std::vector<double> s_texels, s_texel_sigma;
};

}  // namespace aniso
