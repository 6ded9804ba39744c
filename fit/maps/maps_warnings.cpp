#include "fit/maps/maps_warnings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fit/maps/map_holes.h"
#include "models/params.h"

namespace aniso {

namespace {

// The share of the texels inside the sample left undetermined past which the grid is called finer
// than the data support.
constexpr double kFinerThanDataShare = 0.25;

// A texel counts as determined by its fiber direction (and s); its k_d, k_s or n may still be
// known less well than their bounds alone know them (sigma above the bounds' spread, width /
// sqrt 12: a texel whose k_s and n trade off, near a bound). Those are written with their sigma,
// and named here: a number, not a measurement.
void warn_weak_texels(const TexelMaps& m, FitReport* rep) {
  std::string names;
  struct Param {
    const char* key;
    const std::vector<double>* sigma;
    int per;  // numbers per texel
  };
  for (const auto& [key, sigmas, per] :
       {Param{"kd", &m.kd_sigma, 3}, Param{"ks", &m.ks_sigma, 3}, Param{"n", &m.n_sigma, 1}}) {
    const double spread = line_param(key).spread();
    size_t weak = 0;
    for (size_t t = 0; t < m.determined.size(); ++t) {
      bool w = false;
      for (int c = 0; c < per; ++c) w |= (*sigmas)[per * t + c] > spread;
      weak += m.determined[t] && w;
    }
    if (weak)
      names += std::string(names.empty() ? "" : ", ") + key + " in " + std::to_string(weak) +
               (weak == 1 ? " texel" : " texels");
  }
  if (!names.empty())
    rep->warnings.push_back("--maps: the data know " + names +
                            " less well than the parameter's bounds do (sigma above the bounds' "
                            "spread): those values are written with that sigma; do not read them "
                            "as measured (more views or larger texels help)");
}

// A texel whose residual RMS is more than kMisfitTimesNoise times the images' noise: its fit does
// not describe its data (at 80 values a texel, chi^2 / dof of 4 is far past chance: its spread
// under the noise is ~0.16), or its pixels are noisier than the images' median (bright pixels
// under shot noise). Named by count and the worst, with the map to look at.
constexpr double kMisfitTimesNoise = 2;
void warn_misfit_texels(const TexelMaps& m, double noise, FitReport* rep) {
  if (!(noise > 0)) return;
  size_t misfit = 0, worst = 0;
  for (size_t t = 0; t < m.residual.size(); ++t)
    if (m.determined[t] && m.residual[t] > kMisfitTimesNoise * noise) {
      if (misfit++ == 0 || m.residual[t] > m.residual[worst]) worst = t;
    }
  rep->maps_misfit_texels = misfit;
  if (misfit == 0) return;
  const size_t col = worst % static_cast<size_t>(m.w);
  const size_t row = worst / static_cast<size_t>(m.w) + static_cast<size_t>(m.row0);
  char buf[800];
  std::snprintf(buf, sizeof buf,
                "--maps: %zu determined texel%s fit their data with a residual RMS over %g times "
                "the images' noise (%.3g; the worst %.3g, texel column %zu, row %zu): the model "
                "does not describe %s (the material changes within a texel, as at an edge between "
                "materials or where the fibers turn: a finer --maps resolves it; or a scratch, a "
                "spot the views saw differently), or %s pixels are noisier than the images' "
                "median (bright pixels under shot noise). maps_uncertainty.residual holds every "
                "texel's RMS",
                misfit, misfit == 1 ? "" : "s", kMisfitTimesNoise, noise, m.residual[worst], col,
                row, misfit == 1 ? "it" : "them", misfit == 1 ? "its" : "their");
  rep->warnings.push_back(buf);
}

}  // namespace

void add_maps_warnings(const TexelMaps& m, double noise, int iterations, FitReport* rep) {
  // The misfit check judged the one global parameter set; say what the maps leave.
  const size_t before = rep->warnings.size();
  for (auto& warning : rep->warnings)
    if (warning.about == WarningAbout::kGlobalMisfit && m.values > 0) {
      std::string& w = warning.text;
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "one parameter set for the whole sample does not describe the data (residual "
                    "RMS %.3g); with the maps the residual RMS is %.3g (noise of the images %.3g)",
                    rep->rms, m.rms, noise);
      w = buf;
      if (m.rms > 2 * noise && noise > 0)
        w += m.s.empty() ? ": the line model's maps do not describe the data either (try the fiber "
                           "model: --model fiber, or --model auto to compare the two; more "
                           "texels; or check the set)"
                         : ": the maps do not describe the data either (try more texels, or check "
                           "the set)";
    }
  warn_weak_texels(m, rep);
  warn_misfit_texels(m, noise, rep);
  // Undetermined texels of three kinds: with pixels the data do not determine (a warning); with no
  // pixel inside the area the images cover (holes, a warning); with no pixel because no part of
  // the sample lies there (the uv square's corners round a disc: a note).
  const std::vector<uint8_t> hole = fitting::interior_holes(m);
  size_t weak = 0, holes = 0, outside = 0;
  for (size_t t = 0; t < m.determined.size(); ++t) {
    if (m.determined[t]) continue;
    if (m.pixels[t] > 0)
      ++weak;
    else if (hole[t])
      ++holes;
    else
      ++outside;
  }
  // A grid finer than the data support: many texels inside the sample undetermined. A texel's
  // data grow with its area; the grid whose texels are 1 / (share determined) times larger is
  // the one suggested (the same aspect ratio; docs/solver-rules.md "A grid finer than the data").
  const size_t inside = m.determined.size() - outside, lacking = weak + holes;
  if (inside > 0 && lacking > kFinerThanDataShare * inside) {
    const double share = static_cast<double>(inside - lacking) / static_cast<double>(inside);
    std::string support = "no texel is determined: far coarser texels, or more views";
    const int w = static_cast<int>(m.w * std::sqrt(share)),
              h = static_cast<int>((m.row1 - m.row0) * std::sqrt(share));
    if (w >= 1 && h >= 1)
      support = "the data support about " + std::to_string(w) + "x" + std::to_string(h) +
                " (--maps " + std::to_string(w) + "x" + std::to_string(h) +
                "; or more views, or larger images, for this grid)";
    rep->warnings.push_back(
        "--maps: the grid is finer than the data support: " + std::to_string(lacking) + " of the " +
        std::to_string(inside) + " texels inside the sample are not determined; " + support);
  }
  if (weak > 0)
    rep->warnings.push_back(
        "--maps: " + std::to_string(weak) + " of " + std::to_string(m.determined.size()) +
        " texels are not determined by the data (too few pixels, psi's sigma over 10 deg, two "
        "fiber directions that fit a texel's data as well, a lobe the data do not know whose psi "
        "held elsewhere fits nearly as well, or a solver that did not converge): "
        "they hold the global values with the prior's spread as sigma "
        "(maps_uncertainty.determined = 0)");
  if (holes > 0)
    rep->warnings.push_back(
        "--maps: " + std::to_string(holes) +
        " texels inside the area the images cover got no pixel at all: the map is finer than "
        "the images resolve there (texel rows or columns between pixel rows, as on the far side "
        "of a tilted view). They stay undetermined and the maps give them the values of the "
        "nearest determined texels in their column (or row), interpolated; a coarser --maps, "
        "or views that see that part nearer the normal, give them data");
  if (outside > 0)
    rep->notes.push_back("--maps: " + std::to_string(outside) + " of " +
                         std::to_string(m.determined.size()) +
                         " texels lie outside the sample (no pixel's uv falls in them): they hold "
                         "the global values, maps_uncertainty.determined = 0 and coverage 0");
  if (m.not_converged > 0)
    rep->warnings.push_back(
        "--maps: " + std::to_string(m.not_converged) + " texels stopped at " +
        (iterations > 0 ? std::to_string(iterations) + " iterations (--maps-iterations)"
                        : std::string("their iteration limit (--maps-iterations)")) +
        " before their solver converged: marked undetermined, the global values kept");
  for (size_t k = before; k < rep->warnings.size(); ++k)
    rep->warnings[k].about = WarningAbout::kMaps;  // each begins "--maps: "
}

}  // namespace aniso
