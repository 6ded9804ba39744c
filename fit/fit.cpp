// fit: the public entry points. Observations (fit/records/observations.cpp) go to the model's part
// (fit/global/line_fit.cpp, fit/global/fiber_fit.cpp) and the solver (fit/global/solve.cpp), which
// knows only the numbers every model shares; the uncertainty comes from fit/global/uncertainty.cpp
// and the output from fit/report.cpp.
#include "fit/fit.h"

#include <tbb/info.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/angles.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/timer.h"
#include "fit/global/isotropic_alternative.h"
#include "fit/global/psi_symmetry.h"
#include "fit/global/solve.h"
#include "fit/lamps/highlight_lamps.h"
#include "fit/maps/maps.h"
#include "fit/maps/maps_bands.h"
#include "fit/maps/maps_warnings.h"
#include "fit/solvers/start.h"
#include "fit/solvers/texel_lanes.h"
#include "io/files/files.h"
#include "models/params.h"

namespace aniso {

using namespace fitting;

namespace {

using Clock = SteadyClock;

constexpr const char* kNoObservations =
    "fit: no usable observations (empty mask, all pixels saturated, non-finite or unlit)";

// Refuses what cannot be fitted before any work: options that do not go together, no data, more
// parameters than values. `maps_alone` (--maps with --global): nothing global is fitted, and `os`
// is the first band's or the tile's share, which may hold nothing (a sphere's uv leaves rows
// empty): the maps' caller checks the whole instead.
void check_fit_request(const ObsSet& os, const FitOptions& opt, const ModelFit& m,
                       bool maps_alone = false) {
  if (m.model() == Model::kFiber && (opt.fit_isotropic || opt.fit_second))
    throw Error("fit: --fit-isotropic and --fit-second-fiber are available with --model line only");
  if (os.topology == TopologyMode::kTexels && m.model() != Model::kFiber)
    throw Error("fit: --topology-map fits the fiber model's topology: use it with --model fiber");
  if (opt.maps_w > 0 && (opt.model == FitModel::kAuto || opt.fit_isotropic || opt.fit_second))
    throw Error(
        "fit: --maps fits the plain line model or the fiber model per texel: use it with --model "
        "line or fiber and without --fit-isotropic / --fit-second-fiber");
  if (opt.maps_w > 0 && os.topology == TopologyMode::kTexels)
    throw Error("fit: --maps and --topology-map do not go together");
  if (opt.maps_w > 0 && os.texel.size() != os.obs.size())
    throw Error(
        "fit: --maps needs texture coordinates: a capture set with \"uv\" buffers, or a sample "
        "table with u, v columns");
  if (maps_alone) return;
  if (os.obs.empty()) throw Error(kNoObservations);
  if (os.obs.size() * (os.grey ? 1 : 3) <= m.parameters())
    throw Error("fit: " + std::to_string(os.obs.size()) + " observations cannot determine " +
                std::to_string(m.parameters()) + " parameters");
}

// The global values as a material holds them.
Core core_of(const Material& g) {
  Core c;
  for (int k = 0; k < 3; ++k) c.kd[k] = g.kd[k], c.ks[k] = g.ks[k];
  c.logn = std::log(g.n);
  c.psi = deg_to_rad(g.fiber_angle_deg);
  return c;
}

// --maps after the global fit `global` (the fiber model's quadrature order and s with it); the
// misfit warning and the count of undetermined texels go to the report.
// With `bands`, os is band 0's observations and the bands are loaded and fitted one by one.
void add_texel_maps(const ObsSet& os, const FitOptions& opt, const Core& global, int fiber_order,
                    double s, FitReport* rep, FitResult* res, MapsInBands* bands = nullptr) {
  TexelMapOptions to;
  to.w = opt.maps_w, to.h = opt.maps_h, to.rows = tile_rows(opt);
  to.ceres = opt.maps_ceres;
  to.smooth = opt.maps_smooth;
  to.sweeps = opt.maps_sweeps;
  to.max_iterations = opt.maps_iterations;
  to.wide_lanes = opt.maps_lanes != 8;
  to.progress = opt.progress;
  to.fiber_order = fiber_order;
  to.fiber_order_errors = rep->fiber_order_errors;
  to.s = s;
  res->maps = bands ? bands->fit(global, to, rep) : fit_texel_maps(os, global, to);
  const double noise = bands ? bands->pixel_noise() : os.pixel_noise;
  if (!(rep->pixel_noise > 0)) rep->pixel_noise = noise;  // --global: the bands measured it
  add_maps_warnings(res->maps, noise, opt.maps_iterations, rep);
}

FitResult fit_one_model(Model model, const ObsSet& os, const FitOptions& opt, FitReport rep,
                        const RGB& ka) {
  std::unique_ptr<ModelFit> m =
      model == Model::kFiber ? make_fiber_fit(opt, os) : make_line_fit(opt);
  check_fit_request(os, opt, *m);
  const auto t0 = Clock::now();
  Solution sol = solve(m.get(), os, opt, &rep);
  FitResult res;
  Material& mat = res.material;
  const Core& c = m->core;
  for (int k = 0; k < 3; ++k) {
    mat.kd[k] = c.kd[k];
    mat.ks[k] = c.ks[k];
  }
  mat.ka = ka;
  mat.n = std::exp(c.logn);
  mat.fiber_angle_deg = wrap_fiber_deg(rad_to_deg(c.psi));
  m->assemble(os, &res);
  res.fixed["ka"] = "not fitted: taken as 0 (a capture with an ambient says so in the warnings)";
  const auto t_cov = Clock::now();
  estimate_uncertainty(m.get(), os, opt, &sol, &res);
  if (!sol.other_minimum.empty()) {  // a sigma about one of two answers says nothing
    res.sigma.erase("fiber_angle_deg");
    res.undetermined["fiber_angle_deg"] = sol.other_minimum;
    rep.warnings.push_back({"fiber_angle_deg: " + sol.other_minimum, WarningAbout::kFiberAngle});
  }
  rep.covariance = res.report.covariance;
  for (const auto& w : res.report.warnings) rep.warnings.push_back(w);
  rep.seconds_covariance = seconds_since(t_cov);
  rep.fiber_order = m->quadrature_order();
  rep.fiber_order_errors = m->quadrature_errors();
  // The texels start from the global values as the material holds them (psi in degrees, n, not
  // log n), as a --global run reads them back: psi's last bit differed, and a plain run and its
  // tiles then ended a fiber texel one float bit apart.
  if (opt.maps_w > 0)
    add_texel_maps(os, opt, core_of(mat), rep.fiber_order, m->topology_value(), &rep, &res);
  rep.seconds += seconds_since(t0);
  res.report = rep;
  return res;
}

// --global: the global fit read from an earlier run's material; only the maps are fitted here
// (the fiber model's quadrature order: --fiber-order, else the one that fit chose from the whole
// set's noise, else 8: it is not chosen again from a tile's share of the data).
FitResult maps_on_given_global(Model model, const ObsSet& os, const FitOptions& opt, FitReport rep,
                               MapsInBands* bands) {
  std::unique_ptr<ModelFit> m =
      model == Model::kFiber ? make_fiber_fit(opt, os) : make_line_fit(opt);
  check_fit_request(os, opt, *m, true);
  const auto t0 = Clock::now();
  FitResult res;
  res.material = opt.global->material;
  res.material.maps = MaterialMaps{};
  const Material& g = res.material;
  const Core c = core_of(g);
  res.sigma = opt.global->sigma;
  res.fixed["global_fit"] = "from " + opt.global->file + ", not fitted with the maps";
  rep.global_from = opt.global->file;
  rep.solver = "none";
  rep.rms = opt.global->rms;
  // The file's warnings about its global values hold here too; those about its own maps or tile
  // do not (this fit says its own): a --global that was a --maps fit printed each twice.
  for (const auto& w : opt.global->warnings)
    if (w.about != WarningAbout::kMaps && w.about != WarningAbout::kTile) rep.warnings.push_back(w);
  if (opt.global->views > 0 && opt.global->views != rep.views)
    rep.warnings.push_back("--global " + opt.global->file + " was fitted on " +
                           std::to_string(opt.global->views) + " views; this capture has " +
                           std::to_string(rep.views) + ": is it a fit of the same capture?");
  if (model == Model::kFiber) {
    rep.fiber_order = opt.fiber_order > 0 ? opt.fiber_order : opt.global->fiber_order;
    std::string why = opt.fiber_order > 0 ? "as given" : "the global fit's";
    if (rep.fiber_order <= 0) rep.fiber_order = 8, why = "the default: --fiber-order sets it";
    if (opt.fiber_order == 0 && opt.global->fiber_order > 0)
      rep.fiber_order_errors = opt.global->fiber_order_errors;
    rep.start = "texels: quadrature order " + std::to_string(rep.fiber_order) + " (" + why + ")";
    if (rep.fiber_order_errors.count > 0)
      rep.start +=
          ", or lower where a texel's values allow it (the global fit's quadrature errors)";
  }
  // A topology map's amplitude: the global fit's A, over this capture's map (its path as the
  // fit of the capture names it, not as the global fit's file did).
  double topo = g.uniform_s();
  if (const auto* t = g.topology_as<TopologyMapRef>()) {
    topo = t->amplitude;
    res.material.topology = TopologyMapRef{os.topology_map, t->amplitude, os.topology_mathematical};
  }
  add_texel_maps(os, opt, c, rep.fiber_order, topo, &rep, &res, bands);
  if (rep.observations == 0) {
    if (opt.tile_count == 0) throw Error(kNoObservations);
    rep.warnings.push_back({"tile " + std::to_string(opt.tile_index) + "/" +
                                std::to_string(opt.tile_count) +
                                ": no usable pixel's uv falls in its texel rows (the sample's uv "
                                "leaves them empty): every texel of it is undetermined, with the "
                                "global values",
                            WarningAbout::kTile});
  }
  rep.seconds += seconds_since(t0);
  res.report = rep;
  return res;
}

// --model auto fits both models and keeps the one with the lower BIC; otherwise the one asked.
// Ceres logs through glog to stderr; what it says is reported as our own messages instead
// (undetermined parameters, termination), so its raw lines never reach a user's terminal.
void quiet_library_logs() {
  static const bool once = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    FLAGS_stderrthreshold = google::GLOG_FATAL;
    return true;
  }();
  (void)once;
}

FitResult solve_model(const ObsSet& os, const FitOptions& opt, const FitReport& rep, const RGB& ka,
                      MapsInBands* bands = nullptr) {
  quiet_library_logs();
  if (opt.global) {
    const Model given = opt.global->material.model;
    if (opt.maps_w == 0)
      throw Error("fit: --global hands a --maps fit its global fit: give --maps WxH");
    if (opt.model == FitModel::kAuto || (opt.model == FitModel::kFiber) != (given == Model::kFiber))
      throw Error("fit: --global " + opt.global->file + " is a " + model_name(given) +
                  " model fit: --maps fits the same model (give --model " + model_name(given) +
                  ", or leave --model out)");
    const Material& gm = opt.global->material;
    const bool lobe = gm.kd[0] + gm.kd[1] + gm.kd[2] + gm.ks[0] + gm.ks[1] + gm.ks[2] > 0;
    if (!lobe && gm.isotropic_active())
      throw Error("fit: --global " + opt.global->file +
                  ": it is the isotropic part alone (that fit found no anisotropic lobe, "
                  "report.anisotropy_test): fit the global values again with --keep-anisotropic "
                  "to start the texels from the anisotropic fit");
    if (gm.isotropic_active() || gm.second_active())
      throw Error("fit: --global " + opt.global->file +
                  ": it has an isotropic term or a second fiber; --maps fits the plain line model "
                  "or the fiber model");
    if (given == Model::kFiber &&
        (gm.topology_as<TopologyMapRef>() != nullptr) != (os.topology == TopologyMode::kAmplitude))
      throw Error("fit: --global " + opt.global->file +
                  (gm.topology_as<TopologyMapRef>() ? ": it was fitted with a topology map "
                                                      "and this capture names none"
                                                    : ": it was fitted without a topology "
                                                      "map and this capture names one") +
                  ": give the global fit of this capture");
    return maps_on_given_global(given, os, opt, rep, bands);
  }
  if (opt.model != FitModel::kAuto) {
    FitResult r = fit_one_model(opt.model == FitModel::kFiber ? Model::kFiber : Model::kLine, os,
                                opt, rep, ka);
    test_isotropic_alternative(os, opt, &r);
    return r;
  }
  if (opt.progress) opt.progress->status("fit: --model auto: 1/2 the line model");
  FitResult rl = fit_one_model(Model::kLine, os, opt, rep, ka);
  if (opt.progress) opt.progress->status("fit: --model auto: 2/2 the fiber model (the slow half)");
  FitResult rf = fit_one_model(Model::kFiber, os, opt, rep, ka);
  if (opt.progress) opt.progress->status("");
  const bool pick_fiber = rf.report.bic < rl.report.bic;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "BIC = m ln(RSS/m) + k ln m over m = %zu values: line %.1f (RSS %.4g, k = %zu), "
                "fiber %.1f (RSS %.4g, "
                "k = %zu); chose %s (lower by %.1f)",
                rl.report.observations, rl.report.bic, rl.report.rss, rl.report.parameters,
                rf.report.bic, rf.report.rss, rf.report.parameters, pick_fiber ? "fiber" : "line",
                std::abs(rf.report.bic - rl.report.bic));
  FitResult& r = pick_fiber ? rf : rl;
  r.report.model_selection = buf;
  for (const FitResult* x : {&rl, &rf}) {
    std::snprintf(buf, sizeof buf,
                  "%-5s residual RMS %.4g, BIC %.1f, %d iterations, %s, solve %.3f s",
                  model_name(x->material.model), x->report.rms, x->report.bic, x->report.iterations,
                  x->report.termination.c_str(), x->report.seconds_solve);
    r.report.model_summaries.push_back(buf);
  }
  r.report.seconds_solve = rl.report.seconds_solve + rf.report.seconds_solve;
  test_isotropic_alternative(os, opt, &r);
  return r;
}

}  // namespace

size_t export_observations(const CaptureSet& set, const FitOptions& opt, const std::string& path,
                           std::vector<double>* start) {
  FitReport rep;
  const ObsSet os = capture_observations(set, opt, &rep);
  std::vector<double> rows;
  rows.reserve(os.obs.size() * 14);
  size_t n = 0;
  for (size_t i = 0; i < os.obs.size(); ++i) {
    const Observation& o = os.obs[i];
    if (o.num_lights != 1) continue;  // the benchmark scripts model one light per view
    const ObsLight& l = os.lights[o.first_light];
    const double r[14] = {o.V.u,  o.V.w,  o.V.n,  l.L.u,  l.L.w,  l.L.n,       l.E[0],
                          l.E[1], l.E[2], o.y[0], o.y[1], o.y[2], os.smath(i), os.mapv(i)};
    rows.insert(rows.end(), r, r + 14);
    ++n;
  }
  write_atomically(path, [&](const std::string& tmp) {
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw Error(path + ": cannot open for writing");
    const size_t w = std::fwrite(rows.data(), sizeof(double), rows.size(), f);
    std::fclose(f);
    if (w != rows.size()) throw Error(path + ": write failed");
  });
  Core c;
  line_grid_start(os, &c);
  *start = {c.kd[0], c.kd[1], c.kd[2], c.ks[0], c.ks[1], c.ks[2], c.logn, c.psi};
  return n;
}

namespace {

// A plain --maps fit (no --global, no --tile) whose records would pass --maps-memory, or whose
// pixels number more than FitOptions::maps_global_pixels: the every k-th pixel in x and y (k > 1)
// at which the records fit it and the global fit takes at most that many pixels (its values only
// start the texels and fill those the data do not determine); 0 where both hold as they are, or
// the fit is not one the maps in bands can follow (optional terms, --topology-map).
int global_subsample_for(const CaptureSet& set, const FitOptions& opt) {
  if (opt.maps_w == 0 || opt.global || opt.tile_count > 0 || opt.fit_isotropic || opt.fit_second ||
      opt.topology_texels > 0 || set.views.empty())
    return 0;
  for (const ViewSpec& v : set.views)
    if (!v.geometry.mesh.empty()) return 0;  // refused under --maps, by the plain load's check
  BandLoader loader(set, opt);
  // The estimate alone: position, normal and tangent are not decoded for it (the 2048^2 set's
  // 218 MB of geometry were decoded here and again by the load that follows).
  const double bytes = static_cast<double>(loader.record_bytes(true));
  const double budget = opt.maps_memory_mb * 1e6;
  const double pixels = static_cast<double>(loader.record_pixels());
  // A texel is determined by the pixels its spot covers in the views: a grid with more texels than
  // kTexelsPerViewPixel times the pixels a view sees of the sample is finer than the data (memory
  // and time follow the grid, the texels stay undetermined). Refused, with what the data support.
  constexpr double kTexelsPerViewPixel = 4;
  const double per_view = pixels / static_cast<double>(set.views.size());
  const double texels = static_cast<double>(opt.maps_w) * opt.maps_h;
  if (texels > kTexelsPerViewPixel * per_view) {
    const double scale = std::sqrt(kTexelsPerViewPixel * per_view / texels);
    const int w = std::max(1, static_cast<int>(opt.maps_w * scale)),
              h = std::max(1, static_cast<int>(opt.maps_h * scale));
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "fit --maps %dx%d: %.0f texels, but the sample covers %.0f pixels a view (%zu "
                  "views, %.0f pixels in all): the data support at most about %dx%d (%g texels for "
                  "each pixel a view sees); give a coarser --maps, or more or larger views",
                  opt.maps_w, opt.maps_h, texels, per_view, set.views.size(), pixels, w, h,
                  kTexelsPerViewPixel);
    throw Error(buf);
  }
  if (bytes <= budget && pixels <= opt.maps_global_pixels) return 0;
  const int k = static_cast<int>(std::max(std::ceil(std::sqrt(bytes / budget)),
                                          std::ceil(std::sqrt(pixels / opt.maps_global_pixels))));
  return k > 1 ? k : 0;
}

// fit_capture's plain --maps past --maps-memory or its global pixels: the global fit on every k-th
// pixel (k from global_subsample_for), handed to the maps as --global would hand it (band by band
// of texel rows); the result reads as one fit: the global fit's iterations, solver, RMS and choice
// of model, the load times added, and the subsample said.
FitResult maps_after_subsampled_global(const CaptureSet& set, const FitOptions& opt, int k) {
  const auto t0 = Clock::now();
  FitOptions g = opt;
  g.maps_w = g.maps_h = 0;
  g.maps_smooth = 0;
  g.subsample = opt.subsample * k;
  g.test_isotropic = false;
  const FitResult gr = fit_capture(set, g);
  FitOptions m = opt;
  m.global = given_global_of(gr, "this fit's global fit", set.dir);
  if (opt.model == FitModel::kAuto)
    m.model = gr.material.model == Model::kFiber ? FitModel::kFiber : FitModel::kLine;
  FitResult r = fit_capture(set, m);
  FitReport& rep = r.report;
  const FitReport& grep = gr.report;
  rep.global_from.clear();
  r.fixed.erase("global_fit");
  rep.global_subsample = g.subsample;
  rep.start = grep.start;
  rep.iterations = grep.iterations;
  rep.solver = grep.solver;
  rep.termination = grep.termination;
  rep.loss = grep.loss;
  rep.rms = grep.rms;
  rep.covariance = grep.covariance;
  rep.seconds_load += grep.seconds_load;
  rep.seconds_start = grep.seconds_start;
  rep.seconds_solve = grep.seconds_solve;
  rep.seconds_covariance = grep.seconds_covariance;
  rep.model_selection = grep.model_selection;
  rep.model_summaries = grep.model_summaries;
  for (const auto& [key, why] : gr.undetermined) r.undetermined.emplace(key, why);
  rep.seconds = seconds_since(t0);
  return r;
}

FitResult fit_capture_here(const CaptureSet& set, const FitOptions& opt) {
  if (const int k = global_subsample_for(set, opt))
    return maps_after_subsampled_global(set, opt, k);
  const auto t0 = Clock::now();
  FitReport rep;
  if (opt.global && opt.maps_w > 0) {  // the maps alone: band by band of texel rows
    MapsInBands bands(set, opt);
    rep.maps_bands = bands.count();
    rep.maps_record_bytes = bands.record_bytes();
    rep.maps_memory_mb = opt.maps_memory_mb;
    rep.maps_own_geometries = bands.own_geometries();
    const ObsSet& os = bands.load_first(&rep);
    rep.seconds_load = seconds_since(t0);
    FitResult r = solve_model(os, opt, rep, {0, 0, 0}, &bands);
    r.report.seconds = seconds_since(t0);
    return r;
  }
  const ObsSet os = capture_observations(set, opt, &rep);
  rep.seconds_load = seconds_since(t0);
  FitResult r = solve_model(os, opt, rep, {0, 0, 0});
  r.report.seconds = seconds_since(t0);
  return r;
}

// --lamps-from-highlight: the line model fitted under the lamps as given, its material and every
// point lamp fitted together (fit/lamps/highlight_lamps.h), then the fit asked for under the lamps
// found, their sigma as the problem gave it.
FitResult fit_with_lamps_from_highlight(const CaptureSet& set, const FitOptions& opt) {
  if (opt.global || opt.tile_count > 0)
    throw Error(
        "fit: --lamps-from-highlight places the lamps with the global fit: leave out --global and "
        "--tile (fit the global values with it, then give that material to --global)");
  if (opt.model != FitModel::kLine)
    throw Error(
        "fit: --lamps-from-highlight places the lamps with the line model: give --model line");
  const auto t0 = Clock::now();
  FitOptions g = opt;
  g.lamps_from_highlight = LampsFromHighlight::kNever;
  g.maps_w = g.maps_h = 0;
  g.maps_smooth = 0;
  g.fit_isotropic = g.fit_second = false;
  g.test_isotropic = false;
  const FitResult first = fit_capture_here(set, g);
  if (opt.progress) opt.progress->status("fit: the lamps from the sample's highlight");
  const double sigma = std::max(first.report.rms, first.report.pixel_noise);
  FitOptions rest = opt;
  rest.lamps_from_highlight = LampsFromHighlight::kNever;
  const auto placed_at = [&](const HighlightLamps& hl) {
    CaptureSet placed = set;
    for (const HighlightLamp& h : hl.lamps) {
      Light& l = placed.views[h.view].lights[h.light];
      l.position = h.found;
      l.position_sigma_m = h.sigma_m;
    }
    return placed;
  };
  const auto misfit = [](const FitResult& x) {
    for (const Warning& w : x.report.warnings)
      if (w.about == WarningAbout::kGlobalMisfit) return true;
    return false;
  };
  // Where the model misses the data even under the lamps found and the typical lamp moved more
  // than kTypicalLampMovedSigmas, the highlight has moved them to take up the misfit, not to where
  // the lamps are (on shoots rendered with a BRDF the line model does not have they went 8-14 cm
  // astray, 4-7 sigmas the median): the fit is made under the lamps as given, and the lamps'
  // jackknife is not run. One or two lamps far off with the rest in place is what the highlight is
  // there to find.
  constexpr double kTypicalLampMovedSigmas = 3;
  const auto keep = [&](const HighlightLamps& hl) -> std::string {
    std::vector<double> moved;
    for (const HighlightLamp& h : hl.lamps) moved.push_back(h.moved_sigmas);
    std::nth_element(moved.begin(), moved.begin() + moved.size() / 2, moved.end());
    const double typical = moved.empty() ? 0 : moved[moved.size() / 2];
    if (!(typical > kTypicalLampMovedSigmas)) return "";
    const FitResult under = fit_capture_here(placed_at(hl), rest);
    if (!misfit(under)) return "";
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "under the lamps the highlight found the model still misses the data (residual "
                  "RMS %.3g, %.1fx the images' noise) and the typical lamp moved %.1f of its "
                  "sigmas: the highlight would place the lamps where they take up the model's "
                  "misfit",
                  under.report.rms, under.report.rms / std::max(under.report.pixel_noise, 1e-300),
                  typical);
    return buf;
  };
  const HighlightLamps hl = lamps_from_highlight(set, first.material, sigma, opt.threads, keep);
  if (opt.progress) opt.progress->status("");
  const std::string& skipped = hl.skipped;
  FitResult r = fit_capture_here(skipped.empty() ? placed_at(hl) : set, rest);
  FitReport::LampsFromHighlight& out = r.report.lamps_from_highlight;
  out.asked = true;
  out.by_default = opt.lamps_from_highlight == LampsFromHighlight::kAuto;
  out.used = skipped.empty();
  out.skipped = skipped;
  // Asked for, a lamp not placed is a warning; by default, what the fit would have done anyway.
  if (!out.used) {
    const std::string kept =
        "--lamps-from-highlight: the lamps are kept as " + set.file + " gives them: " + skipped;
    if (out.by_default)
      r.report.notes.push_back(kept);
    else
      r.report.warnings.push_back(kept);
  }
  out.pixels = hl.pixels;
  out.views_left_out = hl.views_left_out;
  out.pixel_sigma = hl.pixel_sigma;
  out.iterations = hl.iterations;
  out.seconds = hl.seconds;
  out.jackknife_sigma = hl.jackknife_sigma;
  out.jackknife_views = hl.jackknife_views;
  out.lamp_sigma_scale = hl.lamp_sigma_scale;
  // The lamps were fitted to the same pixels: the views' own residuals, which the whole sigma is
  // the spread of, no longer show the lamps' errors (the lamps took them). Each sigma is at least
  // the jackknife's (a --maps fit's scalars are the maps' means, whose sigma is the texels').
  if (out.used && !hl.jackknife_sigma.empty() && opt.maps_w == 0) {
    const std::pair<const char*, int> at[] = {
        {"kd", 0}, {"ks", 3}, {"n", 6}, {"fiber_angle_deg", 7}};
    for (const auto& [key, k0] : at) {
      auto it = r.sigma.find(key);
      if (it == r.sigma.end()) continue;
      for (size_t i = 0; i < it->second.size(); ++i)
        it->second[i] = std::max(it->second[i], hl.jackknife_sigma[k0 + i]);
    }
    r.uncertainty_basis +=
        "; with the lamps placed by the highlight, at least the spread of a "
        "jackknife over the " +
        std::to_string(hl.jackknife_views) + " views of the lamps' and the material's joint fit";
  }
  for (const HighlightLamp& h : hl.lamps) {
    FitReport::LampPlaced p;
    p.view = h.view, p.light = h.light, p.stated = h.stated, p.pixels = h.pixels;
    p.moved_sigmas = h.moved_sigmas;
    p.released = h.released;
    const Vec3* from[4] = {&h.given, &h.prior_sigma_m, &h.found, &h.sigma_m};
    double* to[4] = {p.given, p.prior_sigma_m, p.found, p.sigma_m};
    for (int a = 0; a < 4; ++a) to[a][0] = from[a]->x, to[a][1] = from[a]->y, to[a][2] = from[a]->z;
    out.lamps.push_back(p);
    if (out.used && h.moved_sigmas > kLampMovedSigmas) {
      const ViewSpec& v = set.views[h.view];
      char buf[600];
      std::snprintf(buf, sizeof buf,
                    "view %zu%s%s: the sample's highlight places its lamp %.0f mm from where %s "
                    "puts it (%.1f of its sigmas): check the lamp's position written for that "
                    "photo (measured from another corner, in another unit, the photo of another "
                    "lamp), and the photo itself (a pose from few corners, a highlight off the "
                    "sample)",
                    h.view, v.source.empty() ? "" : " (",
                    v.source.empty() ? "" : (v.source[0] + ")").c_str(),
                    1e3 * length(h.found - h.given), set.file.c_str(), h.moved_sigmas);
      r.report.warnings.push_back(std::string(buf));
    }
  }
  if (out.used && !hl.lamps.empty()) {
    std::vector<double> mm;
    for (const HighlightLamp& h : hl.lamps) mm.push_back(1e3 * length(h.found - h.given));
    std::sort(mm.begin(), mm.end());
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "the %zu lamps placed again by the sample's highlight together with the "
                  "material: moved %.1f mm (median), at most %.0f mm, from where %s puts them%s",
                  mm.size(), mm[mm.size() / 2], mm.back(), set.file.c_str(),
                  out.by_default ? " (--lamps-as-imported fits under them as given)" : "");
    r.report.notes.push_back(buf);
  }
  r.report.seconds = seconds_since(t0);
  return r;
}

// The capture with each lamp the highlight placed where it placed it (report.lamps_from_highlight);
// `from` names where they came from for an error (a material of another capture).
CaptureSet with_lamps_placed(const CaptureSet& set, const std::vector<LampPlaced>& placed,
                             const std::string& from) {
  CaptureSet out = set;
  for (const LampPlaced& p : placed) {
    if (p.view >= out.views.size() || p.light >= out.views[p.view].lights.size())
      throw Error(from + ": report.lamps_from_highlight places lamp " + std::to_string(p.light) +
                  " of view " + std::to_string(p.view) + ", which " + set.file +
                  " does not have: is it a fit of another capture?");
    Light& l = out.views[p.view].lights[p.light];
    l.position = {p.found[0], p.found[1], p.found[2]};
    l.position_sigma_m = {p.sigma_m[0], p.sigma_m[1], p.sigma_m[2]};
  }
  return out;
}

// The fiber direction from the highlight's symmetry (fit/global/psi_symmetry.h) for the line
// model's global fit: by default where that model misses the data (a lobe of another shape: its
// own psi is then the one its shape fits best, uncertain by degrees), taken where its jackknife's
// sigma is smaller than the model's own and the two agree within 3 of their sigmas; the other
// numbers are then fitted again under it.
FitResult with_psi_from_symmetry(const CaptureSet& set, const FitOptions& opt, FitResult r) {
  if (opt.psi_symmetry == PsiSymmetry::kNever) return r;
  const bool always = opt.psi_symmetry == PsiSymmetry::kAlways;
  FitReport::PsiFromSymmetry rep;
  rep.mode = psi_symmetry_name(opt.psi_symmetry);
  const auto keep = [&](std::string why) {
    rep.why = std::move(why);
    r.report.psi_from_symmetry = rep;
    return r;
  };
  if (r.material.model != Model::kLine || r.material.has_second_fiber)
    return keep("the line model with one fiber direction only");
  if (opt.maps_w > 0 || opt.global || opt.tile_count > 0)
    return keep("the global fit only (a --maps fit has each texel's own psi)");
  bool misfit = false;
  for (const Warning& w : r.report.warnings) misfit |= w.about == WarningAbout::kGlobalMisfit;
  if (!misfit && !always)
    return keep("the line model describes the data (--psi-from-symmetry auto)");
  rep.ran = true;
  rep.why = misfit ? "the line model misses the data" : "asked (--psi-from-symmetry always)";
  if (opt.progress) opt.progress->status("fit: the fiber direction from the highlight's symmetry");
  // Under the lamps the fit was made under: those the highlight placed where it did.
  const CaptureSet lit = r.report.lamps_from_highlight.used
                             ? with_lamps_placed(set, r.report.lamps_from_highlight.lamps, set.file)
                             : set;
  const PsiFromSymmetry ps = psi_from_symmetry(lit, r.material.fiber_angle_deg, opt.threads);
  if (opt.progress) opt.progress->status("");
  rep.psi_deg = ps.psi_deg, rep.sigma_deg = ps.sigma_deg;
  rep.model_psi_deg = r.material.fiber_angle_deg;
  const auto own = r.sigma.find("fiber_angle_deg");
  rep.model_sigma_deg = own == r.sigma.end() ? -1 : own->second[0];
  rep.relative_rms = ps.relative_rms, rep.seconds = ps.seconds;
  rep.views = ps.views, rep.pixels = ps.pixels;
  rep.jackknife_psi_deg = ps.jackknife_psi_deg;
  const double apart = std::abs(std::remainder(ps.psi_deg - rep.model_psi_deg, 180.0));
  char buf[600];
  if (!ps.skipped.empty()) {
    rep.why_not = ps.skipped;
  } else if (ps.views < kMinJackknifeViews) {
    rep.why_not = "its sigma needs at least " + std::to_string(kMinJackknifeViews) + " views";
  } else if (ps.replicate_at_edge) {
    rep.why_not = "a view left out moves it more than 3 degrees: it is not measured";
  } else if (rep.model_sigma_deg >= 0 && !(ps.sigma_deg < rep.model_sigma_deg)) {
    std::snprintf(buf, sizeof buf,
                  "the line model's own psi is surer (sigma %.3g against %.3g deg)",
                  rep.model_sigma_deg, ps.sigma_deg);
    rep.why_not = buf;
  } else if (rep.model_sigma_deg >= 0 &&
             apart > 3 * std::hypot(rep.model_sigma_deg, ps.sigma_deg)) {
    std::snprintf(buf, sizeof buf,
                  "the highlight's symmetry puts the fiber at %.2f +- %.2f deg, %.1f deg from the "
                  "line model's %.2f +- %.2f deg, more than 3 of their sigmas: the lobe is not a "
                  "mirror image of itself across one fiber direction (two fibers: "
                  "--fit-second-fiber; a material that varies over the sample: --maps WxH)",
                  ps.psi_deg, ps.sigma_deg, apart, rep.model_psi_deg, rep.model_sigma_deg);
    rep.why_not = buf;
    r.report.warnings.push_back({std::string(buf), WarningAbout::kFiberAngle});
  }
  std::snprintf(
      buf, sizeof buf,
      "the fiber direction from the highlight's symmetry alone: %.3f +- %.3g deg over %zu "
      "views (the line model's own: %.3f +- %.3g deg)",
      ps.psi_deg, ps.sigma_deg, ps.views, rep.model_psi_deg, rep.model_sigma_deg);
  const std::string said = buf;
  if (!rep.why_not.empty()) {
    r.report.psi_from_symmetry = rep;
    r.report.notes.push_back(said + "; not taken: " + rep.why_not);
    return r;
  }
  FitOptions held = opt;
  held.hold_psi_deg = ps.psi_deg;
  held.psi_symmetry = PsiSymmetry::kNever;
  FitResult h = fit_capture_here(lit, held);
  // The lamps' jackknife widened the other numbers' sigma (fit_with_lamps_from_highlight): kept.
  if (r.report.lamps_from_highlight.used)
    for (auto& [key, s] : h.sigma) {
      const auto was = r.sigma.find(key);
      if (was == r.sigma.end() || was->second.size() != s.size()) continue;
      for (size_t i = 0; i < s.size(); ++i) s[i] = std::max(s[i], was->second[i]);
    }
  h.sigma["fiber_angle_deg"] = {ps.sigma_deg};
  h.undetermined.erase("fiber_angle_deg");
  const auto noise = r.sigma_noise_only.find("fiber_angle_deg");
  if (noise != r.sigma_noise_only.end()) h.sigma_noise_only["fiber_angle_deg"] = noise->second;
  std::snprintf(buf, sizeof buf,
                "; the fiber angle's: the spread of a jackknife over the %zu views of the "
                "highlight's symmetry (the line model's own: %.3f +- %.3g deg), the other numbers "
                "fitted under it",
                ps.views, rep.model_psi_deg, rep.model_sigma_deg);
  h.uncertainty_basis += buf;
  rep.used = true;
  h.report.psi_from_symmetry = rep;
  // What --lamps-from-highlight said of lamps it kept as given (used, it returned above).
  h.report.lamps_from_highlight = r.report.lamps_from_highlight;
  for (const Warning& w : r.report.warnings)
    if (w.text.rfind("--lamps-from-highlight", 0) == 0) h.report.warnings.push_back(w);
  for (const std::string& n : r.report.notes)
    if (n.rfind("--lamps-from-highlight", 0) == 0) h.report.notes.push_back(n);
  h.report.notes.push_back(said + "; taken, the other numbers fitted under it");
  h.report.seconds += r.report.seconds + ps.seconds;
  return h;
}

// Whether the fit places the lamps by the highlight: asked, or by default where the capture states
// its lamps' sigma (what import writes: the lamps are a measurement) for at least
// kMinJackknifeViews views of one inverse-square point lamp and the fit is the line model's from
// the data (not --global, not --tile).
bool places_lamps(const CaptureSet& set, const FitOptions& opt) {
  if (opt.lamps_from_highlight != LampsFromHighlight::kAuto)
    return opt.lamps_from_highlight == LampsFromHighlight::kAlways;
  if (opt.model != FitModel::kLine || opt.global || opt.tile_count > 0) return false;
  size_t stated = 0;
  for (const ViewSpec& v : set.views) {
    if (v.lights.size() != 1 || !inverse_square_point(v.lights[0])) continue;
    const Vec3& s = v.lights[0].position_sigma_m;
    stated += s.x > 0 || s.y > 0 || s.z > 0;
  }
  return stated >= kMinJackknifeViews;
}

FitResult fit_table_here(const SampleTable& t, const FitOptions& opt) {
  const auto t0 = Clock::now();
  FitReport rep;
  const ObsSet os = table_observations(t, opt, &rep);
  FitResult r = solve_model(os, opt, rep, {0, 0, 0});
  r.report.seconds = seconds_since(t0);
  return r;
}

// Every phase of a fit in one arena of --threads: the maps' texels, the band planning and the
// holes' fill ran in TBB's default arena, on every core of the machine whatever --threads said
// (an --mpi rank or a Slurm task sharing a node took all its cores).
template <class F>
FitResult on_threads(const FitOptions& opt, F f) {
  if (opt.maps_lanes == 16 && !fitting::texel_avx512_available())
    throw Error("fit: --maps-lanes 16 needs AVX-512 (F, DQ and VL), which this CPU does not have");
  tbb::task_arena arena(std::max(1, opt.threads));
  return arena.execute(f);
}

}  // namespace

int default_fit_threads() { return std::max(1, tbb::info::default_concurrency()); }

FitResult fit_capture(const CaptureSet& set, const FitOptions& opt) {
  return on_threads(opt, [&] {
    // A global fit made under lamps the highlight placed: the rest of the fit under them too.
    if (opt.global && !opt.global->lamps_placed.empty()) {
      const CaptureSet lit = with_lamps_placed(set, opt.global->lamps_placed, opt.global->file);
      FitResult r = fit_capture_here(lit, opt);
      FitReport::LampsFromHighlight& h = r.report.lamps_from_highlight;
      h.asked = h.used = true;
      h.from_global = opt.global->file;
      h.lamps = opt.global->lamps_placed;
      r.report.notes.push_back(
          "under the " + std::to_string(opt.global->lamps_placed.size()) +
          " lamps as the sample's highlight placed them with the global fit (" + opt.global->file +
          ")");
      return r;
    }
    FitResult r = places_lamps(set, opt) ? fit_with_lamps_from_highlight(set, opt)
                                         : fit_capture_here(set, opt);
    return with_psi_from_symmetry(set, opt, std::move(r));
  });
}

FitResult fit_table(const SampleTable& t, const FitOptions& opt) {
  return on_threads(opt, [&] { return fit_table_here(t, opt); });
}

}  // namespace aniso
