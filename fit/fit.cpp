// fit: the public entry points. Observations (fit/records/observations.cpp) go to the model's part
// (fit/global/line_fit.cpp, fit/global/fiber_fit.cpp) and the solver (fit/global/solve.cpp), which
// knows only the numbers every model shares; the uncertainty comes from fit/global/uncertainty.cpp
// and the output from fit/report.cpp. A photo shoot's steps around a capture's fit (the lamps
// placed by the highlight, the fiber direction from its symmetry) are in fit/fit_steps.cpp.
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
#include "fit/fit_steps.h"
#include "fit/global/isotropic_alternative.h"
#include "fit/global/solve.h"
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

}  // namespace

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

namespace {

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
  return on_threads(opt, [&] { return fit_capture_steps(set, opt); });
}

FitResult fit_table(const SampleTable& t, const FitOptions& opt) {
  return on_threads(opt, [&] { return fit_table_here(t, opt); });
}

}  // namespace aniso
