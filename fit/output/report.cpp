// The fit's output: the material file with its uncertainty and report, its maps, and the tiles of
// a --maps run and their merge. The console's text: fit/report_text.cpp.
#include "fit/output/report.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <limits>
#include <numeric>

#include "fit/maps/map_holes.h"
#include "fit/maps/maps_means.h"
#include "fit/maps/maps_warnings.h"
#include "fit/output/map_previews.h"
#include "fit/output/report_shoot.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "models/params.h"

namespace aniso {

std::vector<std::string> map_files(const std::string& material_path) {
  const std::string stem = std::filesystem::path(material_path).stem().string();
  std::vector<std::string> f;
  for (const char* k : {"kd", "ks", "n", "fiber", "kd_sigma", "ks_sigma", "n_sigma", "fiber_sigma",
                        "coverage", "determined", "s", "s_sigma", "amplitude", "amplitude_sigma",
                        "topology_s", "residual"})  // topology_s: --topology-map's map of s
    f.push_back(stem + "_" + k + ".exr");
  return f;
}

namespace {

// The blocks of a material that name files of its maps' generation.
constexpr const char* kMapBlocks[] = {"maps", "maps_uncertainty", "topology", "previews"};

// The file names an aniso material at `path` gives in its map blocks (none, if there is no file
// there, it is not a material, or aniso did not write it).
std::vector<std::string> named_maps(const std::string& path) {
  std::vector<std::string> named;
  if (!std::filesystem::is_regular_file(path) || stamped_kind(path) != "material") return named;
  try {
    const jsonu::json j = jsonu::json::parse(read_text_file(path));
    for (const char* block : kMapBlocks)
      if (j.is_object() && j.contains(block) && j[block].is_object())
        for (const auto& [key, v] : j[block].items())
          if (v.is_string() && key != "map") named.push_back(v.get<std::string>());
  } catch (const std::exception&) {
    named.clear();
  }
  return named;
}

// Every string value in the material's map blocks that is a plain name of this generation,
// renamed to the name it has beside the material.
void rename_maps(const std::map<std::string, std::string>& names, jsonu::json* j) {
  for (const char* block : kMapBlocks)
    if (j->contains(block) && (*j)[block].is_object())
      for (auto& [key, v] : (*j)[block].items())
        if (v.is_string() && names.count(v.get<std::string>())) v = names.at(v.get<std::string>());
}

}  // namespace

namespace {

// A report's warnings: their texts, and beside them what each is about (report.warnings_about),
// which a reader picks them out by.
void put_warnings(const std::vector<Warning>& warnings, jsonu::json* report) {
  std::vector<std::string> texts, about;
  for (const auto& w : warnings) {
    texts.push_back(w.text);
    about.push_back(warning_about_name(w.about));
  }
  (*report)["warnings"] = texts;
  (*report)["warnings_about"] = about;
}

// The same read back; a file without warnings_about (or with another count) is read by the words
// each kind of warning began with when it was written.
std::vector<Warning> warnings_read_back(const jsonu::json& report) {
  std::vector<Warning> out;
  const jsonu::json texts = report.value("warnings", jsonu::json::array());
  const jsonu::json about = report.value("warnings_about", jsonu::json::array());
  const bool named = about.is_array() && about.size() == texts.size();
  for (size_t k = 0; texts.is_array() && k < texts.size(); ++k) {
    if (!texts[k].is_string()) continue;
    const std::string t = texts[k].get<std::string>();
    out.push_back({t, named && about[k].is_string()
                          ? warning_about_named(about[k].get<std::string>())
                          : warning_about_from_words(t)});
  }
  return out;
}

// --maps: the maps (docs/formats.md "Material maps") of the material at `path`, written into
// `dir` under their plain names, and those names in j (write_material renames both).
void add_maps(const std::string& path, const std::string& dir, const TexelMaps& t, jsonu::json* j,
              ExrCompression compression) {
  const std::vector<std::string> f = map_files(path);
  const size_t N = static_cast<size_t>(t.w) * t.h;
  // Each file as one job: compressed (zlib) one after the other they are the whole run's serial
  // tail for a large map. The files are independent: written in parallel.
  std::vector<std::function<void()>> writes;
  auto put = [&](size_t file, int channels, auto value) {
    writes.push_back([&, file, channels, value] {
      Image img(t.w, t.h, channels);
      // A sigma past float's range (a texel whose n the data barely touch: 1e140 was seen) is
      // written as float's largest: "not known at all", where the cast would make it Inf.
      constexpr double kMax = std::numeric_limits<float>::max();
      for (size_t i = 0; i < N; ++i)
        for (int c = 0; c < channels; ++c)
          img.px[channels * i + c] =
              static_cast<float>(std::clamp<double>(value(i, c), -kMax, kMax));
      write_exr(join_path(dir, f[file]), img, compression);
    });
  };
  const double d2r = M_PI / 90;                                 // doubled angle, degrees to radians
  const fitting::WrittenValues v = fitting::written_values(t);  // holes filled
  put(0, 3, [&](size_t i, int c) { return v.kd[3 * i + c]; });
  put(1, 3, [&](size_t i, int c) { return v.ks[3 * i + c]; });
  put(2, 1, [&](size_t i, int) { return v.n[i]; });
  put(3, 2, [&](size_t i, int c) {
    return c == 0 ? std::cos(d2r * v.psi_deg[i]) : std::sin(d2r * v.psi_deg[i]);
  });
  put(4, 3, [&](size_t i, int c) { return t.kd_sigma[3 * i + c]; });
  put(5, 3, [&](size_t i, int c) { return t.ks_sigma[3 * i + c]; });
  put(6, 1, [&](size_t i, int) { return t.n_sigma[i]; });
  put(7, 1, [&](size_t i, int) { return t.psi_sigma_deg[i]; });
  put(8, 1, [&](size_t i, int) { return t.pixels[i]; });
  put(9, 1, [&](size_t i, int) { return t.determined[i]; });
  // The fiber model's topology per texel (docs/formats.md: maps.s, or maps.amplitude over a
  // topology map; channel R).
  const size_t s_file = t.s_key == "amplitude" ? 12 : 10;
  if (!t.s.empty()) {
    put(s_file, 1, [&](size_t i, int) { return v.s[i]; });
    put(s_file + 1, 1, [&](size_t i, int) { return t.s_sigma[i]; });
  }
  constexpr size_t kResidualFile = 15;
  if (!t.residual.empty())  // (a merge of tiles from before it has none)
    put(kResidualFile, 1, [&](size_t i, int) { return t.residual[i]; });
  writes.push_back([&] { write_map_previews(path, dir, t, v.kd, v.ks, v.n, v.psi_deg); });
  tbb::parallel_for(size_t{0}, writes.size(), [&](size_t k) { writes[k](); });
  (*j)["previews"] = {{"note",
                       "8-bit pictures of the maps for a person, not read back: kd and ks in sRGB "
                       "(ks scaled to its largest texel), n on a log scale from the map's smallest "
                       "to its largest, the fiber direction as hue (the doubled angle round the "
                       "colour wheel); texels the data do not determine dimmed to a quarter"}};
  for (const MapPreview& p : map_preview_files(path)) (*j)["previews"][p.key] = p.file;
  (*j)["maps"] = {{"kd", f[0]}, {"ks", f[1]}, {"n", f[2]}, {"fiber", f[3]}, {"wrap", "clamp"}};
  (*j)["maps_uncertainty"] = {
      {"kd", f[4]},
      {"ks", f[5]},
      {"n", f[6]},
      {"fiber", f[7]},
      {"coverage", f[8]},
      {"determined", f[9]},
      {"texels", {t.w, t.h}},
      {"note",
       "one standard deviation per texel (fiber: R = sigma of psi in degrees); "
       "coverage: pixels per texel; determined = 0: not determined by the data, sigma is the "
       "prior's spread and the value the global one, or, for a texel no pixel reaches between "
       "texels that have pixels, the nearest determined texels' in its column (else row), "
       "interpolated; a determined texel whose n sigma is float's largest showed no specular "
       "lobe: its n is the global one (the fiber model's k_s 0, its sigma float's largest too)"}};
  if (!t.residual.empty()) {
    (*j)["maps_uncertainty"]["residual"] = f[kResidualFile];
    (*j)["maps_uncertainty"]["note"] =
        (*j)["maps_uncertainty"]["note"].get<std::string>() +
        "; residual: the RMS of a texel's residuals (image units, each channel a value; -1 where "
        "no problem was solved), to hold against the images' noise (report.pixel_noise)";
  }
  if (!t.s.empty()) {
    (*j)["maps"][t.s_key] = f[s_file];
    (*j)["maps_uncertainty"][t.s_key] = f[s_file + 1];
  }
  if (t.smooth > 0)
    (*j)["maps_uncertainty"]["smooth"] = {
        {"lambda", t.smooth},
        {"sweeps", t.sweeps},
        {"note",
         "each texel pulled toward its 4 neighbours; sigma is from the texel's own data alone "
         "(the pull would make it smaller: these are an upper bound)"}};
}

// The fiber texels solved at each quadrature order, as the report keeps them: {"4": 1201, ...};
// and back (adding to *by).
constexpr int kMaxOrder = FiberOrderErrors::kMaxOrder;
jsonu::json orders_json(const size_t (&by)[kMaxOrder + 1]) {
  jsonu::json j = jsonu::json::object();
  for (int k = 0; k <= kMaxOrder; ++k)
    if (by[k] > 0) j[std::to_string(k)] = by[k];
  return j;
}
void add_orders(const jsonu::json& j, size_t (*by)[kMaxOrder + 1]) {
  if (!j.is_object()) return;
  for (const auto& [k, v] : j.items()) {
    const int order = std::atoi(k.c_str());
    if (order >= 1 && order <= kMaxOrder && v.is_number_unsigned()) (*by)[order] += v.get<size_t>();
  }
}

// report.fiber_order_errors: the quadrature's error per value at each order the global fit tried,
// and the noise it was held against (FiberOrderErrors); read back for --global and tiles.
jsonu::json order_errors_json(const FiberOrderErrors& e) {
  jsonu::json rms = jsonu::json::array();
  for (int k = 0; k < e.count; ++k) rms.push_back({e.order[k], e.rms[k]});
  return {{"noise", e.noise},
          {"rms_per_value", rms},
          {"note",
           "the quadrature's RMS error per value against order 16 at the global fit's start, per "
           "order tried; each --maps texel takes the smallest order whose error is under 1 % of "
           "noise / sqrt(its values), at most fiber_order"}};
}
FiberOrderErrors order_errors_from(const jsonu::json& j, const std::string& file) {
  const std::string key = file + ": report.fiber_order_errors";
  FiberOrderErrors e;
  if (!j.is_object() || !j.contains("noise") || !j["noise"].is_number() ||
      !j.contains("rms_per_value") || !j["rms_per_value"].is_array())
    throw Error(key + ": expected {\"noise\": number, \"rms_per_value\": [[order, rms], ...]}");
  e.noise = j["noise"].get<double>();
  if (!(std::isfinite(e.noise) && e.noise > 0)) throw Error(key + ".noise: not a positive number");
  const jsonu::json& rms = j["rms_per_value"];
  if (rms.size() > FiberOrderErrors::kMaxOrders)
    throw Error(key + ".rms_per_value: more than " + std::to_string(FiberOrderErrors::kMaxOrders) +
                " orders");
  for (const auto& pair : rms) {
    if (!pair.is_array() || pair.size() != 2 || !pair[0].is_number_integer() ||
        !pair[1].is_number())
      throw Error(key + ".rms_per_value: each entry is [order, rms]");
    const long long order = pair[0].get<long long>();
    const double r = pair[1].get<double>();
    if (order < 1 || order > kMaxOrder || (e.count > 0 && order <= e.order[e.count - 1]))
      throw Error(key + ".rms_per_value: orders from 1 to 16, ascending");
    if (!(std::isfinite(r) && r >= 0)) throw Error(key + ".rms_per_value: an rms is not >= 0");
    e.order[e.count] = static_cast<int>(order), e.rms[e.count] = r, ++e.count;
  }
  return e;
}

// The report's part of a material file: what the fit saw, how it went, where the time went.
jsonu::json report_json(const FitReport& p) {
  jsonu::json j = {{"residual_rms", p.rms},
                   {"noise_sigma_robust", p.noise_sigma},
                   {"pixel_noise", p.pixel_noise},
                   {"observations", p.observations},
                   {"pixels", p.pixels},
                   {"views", p.views},
                   {"skipped",
                    {{"masked_out", p.masked_out},
                     {"saturated", p.saturated},
                     {"nonfinite", p.nonfinite},
                     {"unlit", p.unlit},
                     {"implausible", p.implausible}}},
                   {"iterations", p.iterations},
                   {"time_s", p.seconds},
                   {"time_breakdown_s",
                    {{"load", p.seconds_load},
                     {"start", p.seconds_start},
                     {"solve", p.seconds_solve},
                     {"covariance", p.seconds_covariance}}},
                   {"termination", p.termination},
                   {"loss", p.loss},
                   {"covariance", p.covariance},
                   {"solver", p.solver},
                   {"start", p.start},
                   {"residual_evaluations", p.residual_evaluations},
                   {"rss", p.rss},
                   {"bic", p.bic},
                   {"parameters", p.parameters},
                   {"jacobian_evaluations", p.jacobian_evaluations}};
  if (!p.pass.empty()) j["pass"] = p.pass;
  if (p.stopped_on_crawl) j["stopped_on_crawl"] = true;
  if (!p.convergence.empty() && std::all_of(p.convergence.begin(), p.convergence.end(),
                                            [](double c) { return std::isfinite(c); }))
    j["convergence"] = {{"cost", p.convergence},
                        {"note",
                         "the solver's cost (its sum of squared residuals, robust where a loss "
                         "applies, each solver in its own scale) at its start and after each "
                         "accepted step"}};
  if (!p.capture_fingerprint.empty()) j["capture_fingerprint"] = p.capture_fingerprint;
  if (!p.capture_layout.empty()) j["capture_layout"] = p.capture_layout;
  if (!p.options_fingerprint.empty()) j["options_fingerprint"] = p.options_fingerprint;
  if (p.staged_stride > 1)
    j["staged"] = {{"every_kth_pixel", p.staged_stride}, {"iterations", p.staged_iterations}};
  if (!p.global_from.empty()) j["global_from"] = p.global_from;
  if (p.fiber_order > 0) j["fiber_order"] = p.fiber_order;
  if (p.fiber_order_errors.count > 0)
    j["fiber_order_errors"] = order_errors_json(p.fiber_order_errors);
  if (p.outside_tile > 0) j["skipped"]["outside_tile"] = p.outside_tile;
  if (p.maps_bands > 0) j["maps_bands"] = p.maps_bands;
  if (p.maps_bands > 0) j["maps_band_peak_bytes"] = p.maps_band_peak_bytes;
  if (p.maps_bands > 0) j["maps_band_shared_bytes"] = p.maps_band_shared_bytes;
  if (p.global_subsample > 0) j["global_subsample"] = p.global_subsample;
  if (p.implausible_limit > 0) j["implausible_limit"] = p.implausible_limit;
  if (!p.model_selection.empty()) j["model_selection"] = p.model_selection;
  if (p.anisotropy.tested) {
    const auto& t = p.anisotropy;
    j["anisotropy_test"] = {
        {"values", t.values},
        {"bic_anisotropic", t.bic_anisotropic},
        {"bic_isotropic", t.bic_isotropic},
        {"lobe_share", t.lobe_share},
        {"preferred", t.isotropic_preferred ? "isotropic" : "anisotropic"},
        {"bic_line_with_isotropic",
         t.with_both_tested ? jsonu::json(t.bic_with_both) : jsonu::json(nullptr)},
        {"written", t.isotropic_written ? "isotropic" : "anisotropic"},
        {"isotropic",
         {{"kd", {t.iso_kd[0], t.iso_kd[1], t.iso_kd[2]}},
          {"ks", {t.iso_ks[0], t.iso_ks[1], t.iso_ks[2]}},
          {"n", t.iso_n}}}};
  }
  if (p.lamps_from_highlight.asked)
    j["lamps_from_highlight"] = lamps_from_highlight_json(p.lamps_from_highlight);
  if (!p.psi_from_symmetry.mode.empty())
    j["psi_from_symmetry"] = psi_from_symmetry_json(p.psi_from_symmetry);
  if (!p.warnings.empty()) put_warnings(p.warnings, &j);
  if (!p.notes.empty()) j["notes"] = p.notes;
  if (p.measured_rel_rms >= 0) {
    jsonu::json by = jsonu::json::array();
    for (const auto& [theta, e] : p.measured_rel_rms_by_angle)
      by.push_back({{"theta_view_deg", theta}, {"relative_rms", e}});
    j["measured"] = {{"relative_rms", p.measured_rel_rms},
                     {"median_relative_error", p.measured_median_rel},
                     {"by_view_angle", by}};
  }
  return j;
}

// A maps material's scalar values are the means of its determined texels (docs/formats.md
// "Material maps": the scalar keys stay, as mean values), each with the sigma of its mean; the one
// global fit (every texel's start, and the values of texels the data do not determine) is kept as
// report.global, and read back from there by given_global.
void put_maps_means(const TexelMaps& t, jsonu::json* j) {
  const MapsMeans mm = maps_means(t);
  jsonu::json& J = *j;
  jsonu::json g = jsonu::json::object(), gu = jsonu::json::object();
  const jsonu::json unc = J.value("uncertainty", jsonu::json::object());
  for (const char* k : {"kd", "ks", "n", "fiber_angle_deg"}) {
    g[k] = J[k];
    if (unc.contains(k)) gu[k] = unc[k];
  }
  const bool s = mm.has_s && J.contains("topology") && J["topology"].contains("s");
  if (s) {
    g["topology"] = {{"s", J["topology"]["s"]}};
    if (unc.contains("topology") && unc["topology"].contains("s"))
      gu["topology"] = {{"s", unc["topology"]["s"]}};
  }
  g["uncertainty"] = gu;
  g["note"] =
      "the one global fit of the whole sample: every texel's start, and the values of the texels "
      "the data do not determine; report.uncertainty_noise_only, fixed and undetermined are its";
  J["report"]["global"] = g;
  if (mm.texels == 0) {
    J["report"]["maps_means"] = {
        {"texels", 0},
        {"note", "no texel is determined: the scalar values are the global fit's (report.global)"}};
    return;
  }
  J["kd"] = {mm.kd[0], mm.kd[1], mm.kd[2]};
  J["ks"] = {mm.ks[0], mm.ks[1], mm.ks[2]};
  J["n"] = mm.n;
  J["fiber_angle_deg"] = mm.psi_deg;
  J["uncertainty"]["kd"] = {mm.kd_sigma[0], mm.kd_sigma[1], mm.kd_sigma[2]};
  J["uncertainty"]["ks"] = {mm.ks_sigma[0], mm.ks_sigma[1], mm.ks_sigma[2]};
  J["uncertainty"]["n"] = mm.n_sigma;
  J["uncertainty"]["fiber_angle_deg"] = mm.psi_sigma_deg;
  if (s) {
    J["topology"]["s"] = mm.s;
    J["uncertainty"]["topology"]["s"] = mm.s_sigma;
  }
  J["report"]["maps_means"] = {
      {"texels", mm.texels},
      {"note",
       "kd, ks, n and fiber_angle_deg (and topology.s) are the means over these determined texels "
       "(fiber_angle_deg: the mean direction of the doubled angle); their uncertainty is the "
       "sigma of each mean from the texels' own sigmas; report.global holds the one global fit"}};
}

// What write_fit writes, maps aside. A map of s (--topology-map) goes into *s_map (R = s, G = its
// sigma, -1 where undetermined) under the name the material gives it; without s_map it is written
// beside the material at once (a tile's).
jsonu::json fit_json(const std::string& path, const FitResult& r, Image* s_map = nullptr,
                     ExrCompression compression = ExrCompression::kZip) {
  jsonu::json j;
  Material m = r.material;
  std::string s_map_path;
  if (!r.s_texels.empty()) {
    std::string stem = std::filesystem::path(path).stem().string();
    m.topology = SMapRef{stem + "_topology_s.exr"};
    s_map_path = join_path(parent_dir(path), stem + "_topology_s.exr");
  }
  // Paths in a written file are relative to that file.
  if (auto* t = m.topology_as<TopologyMapRef>(); t && path != "-")
    t->file = relative_to(t->file, parent_dir(path));
  material_to_json(m, &j);
  if (!r.s_texels.empty()) j["topology"]["s_map_texels"] = r.s_texels_n;
  auto uncertainty = [&](const std::map<std::string, std::vector<double>>& sigma) {
    jsonu::json unc = jsonu::json::object();
    for (const auto& [key, v] : sigma) {
      const auto dot = key.find('.');
      jsonu::json val = v.size() == 1 ? jsonu::json(v[0]) : jsonu::json(v);
      if (dot == std::string::npos)
        unc[key] = val;
      else
        unc[key.substr(0, dot)][key.substr(dot + 1)] = val;
    }
    for (const auto& [key, why] : r.undetermined)
      if (key != "covariance") unc[key] = nullptr;
    return unc;
  };
  j["uncertainty"] = uncertainty(r.sigma);
  j["fixed"] = r.fixed;
  if (!r.undetermined.empty()) j["undetermined"] = r.undetermined;
  j["report"] = report_json(r.report);
  if (!r.uncertainty_basis.empty()) {
    j["report"]["uncertainty"] = r.uncertainty_basis;
    j["report"]["uncertainty_noise_only"] = uncertainty(r.sigma_noise_only);
  }
  if (!r.correlation.empty())
    j["report"]["correlation"] = {{"parameters", r.correlation_names},
                                  {"matrix", r.correlation},
                                  {"note",
                                   "correlation of the fitted numbers in the solver's coordinates "
                                   "(log n, angles in radians)"}};
  if (!s_map_path.empty()) {
    Image img(r.s_texels_n, r.s_texels_n, 2);
    for (size_t i = 0; i < r.s_texels.size(); ++i) {
      img.px[2 * i] = static_cast<float>(r.s_texels[i]);
      img.px[2 * i + 1] = static_cast<float>(r.s_texel_sigma[i]);
    }
    if (s_map)
      *s_map = std::move(img);
    else
      write_exr(s_map_path, img, compression);
  }
  return j;
}

// Writes the material j at `path` with the map files `fill` writes (plain names, into the folder
// it is given) as one output: the maps as a new generation beside it, then the material naming
// them, then the generation the material there before named is removed (io/files/files.h).
void write_material(const std::string& path, jsonu::json* j,
                    const std::function<void(const std::string&)>& fill) {
  if (path == "-")
    throw Error(
        "fit: --maps and --topology-map write map files beside the material: give --out "
        "a file");
  const std::vector<std::string> earlier = named_maps(path);
  const auto names = write_generation(path, fill);
  rename_maps(names, j);
  write_json_file(path, *j);
  std::vector<std::string> now;
  for (const auto& [plain, name] : names) now.push_back(name);
  // What the material there names now (a concurrent run's) is kept as well.
  for (const auto& n : named_maps(path)) now.push_back(n);
  remove_generation(path, earlier, now);
}

}  // namespace

std::string fit_text(const FitResult& r) {
  if (r.maps.w > 0) throw Error("fit_text: a result with maps is written by write_fit");
  return fit_json("fit.json", r).dump();
}

GivenGlobal given_global(const std::string& text, const std::string& file,
                         const std::string& base_dir) {
  jsonu::json j = jsonu::parse_file(text, file);
  GivenGlobal g;
  g.file = file;
  // Read once; its maps (of an earlier --maps fit) are not loaded: only the global values count.
  const jsonu::json rep = j.value("report", jsonu::json::object());
  // A maps material: its scalars are the maps' means; the global fit, values and uncertainty, is
  // report.global, laid over them.
  if (rep.is_object() && rep.contains("global") && rep["global"].is_object()) {
    jsonu::json patch = rep["global"];
    patch.erase("note");
    j.merge_patch(patch);
  }
  g.material = material_from_json(j, file);
  g.material.base_dir = base_dir;
  if (rep.is_object()) {
    const int order = rep.value("fiber_order", 0);
    if (order >= 1 && order <= 16) g.fiber_order = order;
    if (rep.contains("fiber_order_errors"))
      g.fiber_order_errors = order_errors_from(rep["fiber_order_errors"], file);
    g.views = rep.value("views", size_t(0));
    const double limit = rep.value("implausible_limit", 0.0);
    if (std::isfinite(limit) && limit > 0) g.implausible_limit = limit;
    g.rms = rep.value("residual_rms", 0.0);
    if (rep.contains("capture_layout") && rep["capture_layout"].is_string())
      g.capture_layout = rep["capture_layout"].get<std::string>();
    g.warnings = warnings_read_back(rep);
    g.lamps_placed = lamps_placed_read_back(rep, file);
  }
  // "uncertainty": a number or an array per key; null where undetermined.
  const jsonu::json unc = j.value("uncertainty", jsonu::json::object());
  if (!unc.is_object()) return g;
  for (const auto& [key, v] : unc.items()) {
    std::vector<double> s;
    if (v.is_number()) s.push_back(v.get<double>());
    if (v.is_array())
      for (const auto& x : v)
        if (x.is_number()) s.push_back(x.get<double>());
    if (!s.empty() && std::all_of(s.begin(), s.end(), [](double x) { return std::isfinite(x); }))
      g.sigma[key] = s;
  }
  return g;
}

GivenGlobal given_global_of(const FitResult& r, const std::string& file,
                            const std::string& base_dir) {
  if (r.maps.w > 0) throw Error("given_global_of: a result with maps");
  GivenGlobal g;
  g.file = file;
  g.material = r.material;
  g.material.base_dir = base_dir;
  const FitReport& rep = r.report;
  if (rep.fiber_order >= 1 && rep.fiber_order <= 16) g.fiber_order = rep.fiber_order;
  if (rep.fiber_order_errors.count > 0) g.fiber_order_errors = rep.fiber_order_errors;
  g.views = rep.views;
  if (std::isfinite(rep.implausible_limit) && rep.implausible_limit > 0)
    g.implausible_limit = rep.implausible_limit;
  g.rms = rep.rms;
  g.capture_layout = rep.capture_layout;
  g.warnings = rep.warnings;
  if (rep.lamps_from_highlight.used) g.lamps_placed = rep.lamps_from_highlight.lamps;
  // As the file's "uncertainty" is read: the top-level keys with finite values, not those the
  // data do not determine (null there), not the nested ones ("topology.s").
  for (const auto& [key, v] : r.sigma) {
    if (key.find('.') != std::string::npos || r.undetermined.count(key) || v.empty()) continue;
    if (std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); }))
      g.sigma[key] = v;
  }
  return g;
}

void write_fit(const std::string& path, const FitResult& r, ExrCompression maps) {
  if (r.maps.w == 0 && r.s_texels.empty()) {
    write_json_file(path, fit_json(path, r, nullptr, maps));
    return;
  }
  Image s_map;
  jsonu::json j = fit_json(path, r, &s_map);
  if (r.maps.w > 0) {
    j["report"]["time_breakdown_s"]["texels"] = r.maps.seconds;  // the maps' own phase
    j["report"]["maps_threads"] = r.maps.threads;
    j["report"]["maps_float_lanes"] = r.maps.lanes;
    j["report"]["maps_misfit_texels"] = r.report.maps_misfit_texels;
    if (r.report.fiber_order > 0)
      j["report"]["maps_quadrature_orders"] = orders_json(r.maps.texels_by_order);
    put_maps_means(r.maps, &j);
  }
  write_material(path, &j, [&](const std::string& dir) {
    if (!r.s_texels.empty())
      write_exr(join_path(dir, std::filesystem::path(path).stem().string() + "_topology_s.exr"),
                s_map, maps);
    if (r.maps.w > 0) add_maps(path, dir, r.maps, &j, maps);
  });
}

void write_maps_tile(const std::string& path, const FitResult& r, const FitOptions& opt) {
  const TexelMaps& t = r.maps;  // its arrays hold the tile's rows
  jsonu::json values = jsonu::json::object();
  for (const auto& arr : kTexelArrays)
    if (!(t.*arr.d).empty()) values[arr.key] = t.*arr.d;
  values["pixels"] = t.pixels;
  values["determined"] = std::vector<int>(t.determined.begin(), t.determined.end());
  const jsonu::json j = {{"format", "aniso-maps-tile"},
                         {"version", 1},
                         {"tile", {opt.tile_index, opt.tile_count}},
                         {"texels", {t.w, t.h}},
                         {"rows", {t.row0, t.row1}},
                         {"smooth", {t.smooth, t.sweeps}},
                         {"s_key", t.s_key},
                         {"fitted", t.fitted},
                         {"not_converged", t.not_converged},
                         {"sum_sq", t.sum_sq},
                         {"residual_values", t.values},
                         {"maps_iterations", opt.maps_iterations},
                         {"seconds", t.seconds},
                         {"quadrature_orders", orders_json(t.texels_by_order)},
                         {"fit", fit_json(path, r)},
                         {"values", values}};
  write_json_file(path, j);
}

void merge_maps_tiles(const std::vector<std::string>& tiles, const std::string& out,
                      ExrCompression maps) {
  if (tiles.empty()) throw Error("merge: no tiles given");
  TexelMaps m;
  jsonu::json fit;
  int count = -1, iterations = 0;
  std::vector<int> seen;
  std::vector<double> noise;  // each tile's measure of the images' noise
  // With --global each tile counted the pixels of its own rows (kept, and left out by reason):
  // their sums are the untiled run's. Without, every tile's counts are one global fit's.
  bool own_counts = true;
  jsonu::json counts = {{"pixels", 0},    {"observations", 0}, {"saturated", 0},
                        {"nonfinite", 0}, {"unlit", 0},        {"implausible", 0}};
  // Each tile's own time (tile order) and the phases' sums: the work of the whole grid, where the
  // report held tile 0's alone.
  std::vector<double> tile_time;
  jsonu::json phases = jsonu::json::object();
  // A grid is allocated from the first tile's header: the tiles' bytes bound it (a JSON value
  // takes at least 2 bytes, and a texel has at least 5 values), so a damaged or forged tile
  // cannot make the merge allocate past what it was given.
  uintmax_t tile_bytes = 0;
  for (const auto& path : tiles) {
    std::error_code ec;
    const uintmax_t b = std::filesystem::file_size(path, ec);
    if (!ec) tile_bytes += b;
  }
  std::string capture_fp, options_fp;
  constexpr size_t kMaxTileBytes = size_t(1) << 36;  // 64 GiB: the merge holds one tile at once
  for (const auto& path : tiles) try {
      const jsonu::json j = jsonu::parse_file(read_text_file(path, kMaxTileBytes), path);
      const jsonu::Ctx c{path, ""};
      if (!j.is_object() || j.value("format", "") != "aniso-maps-tile")
        c.fail(
            "not a tile of a maps fit (format \"aniso-maps-tile\", from aniso fit --maps --tile)");
      const int i = j.at("tile").at(0), n = j.at("tile").at(1);
      const int w = j.at("texels").at(0), h = j.at("texels").at(1);
      const int r0 = j.at("rows").at(0), r1 = j.at("rows").at(1);
      if (n < 1 || n > 100000 || w < 1 || h < 1 || w > 16384 || h > 16384)
        c.fail("tile count or grid size out of range");
      if (n > h)
        c.at("tile").fail("a grid of " + std::to_string(h) + " texel rows is cut into at most " +
                          std::to_string(h) + " tiles, not " + std::to_string(n));
      if (!j.contains("values") || !j["values"].is_object())
        c.at("values").fail("missing: not a whole tile");
      if (!j.contains("fit") || !j["fit"].is_object())
        c.at("fit").fail("missing: not a whole tile");
      if (count < 0 && static_cast<uintmax_t>(w) * h * 10 > tile_bytes)
        c.at("texels").fail("declares a " + std::to_string(w) + "x" + std::to_string(h) +
                            " grid, more than the " + std::to_string(tiles.size()) + " tiles' " +
                            std::to_string(tile_bytes) +
                            " bytes can hold (a damaged tile, or tiles missing)");
      const jsonu::json& rep0 = j["fit"].value("report", jsonu::json::object());
      const std::string cfp = rep0.value("capture_fingerprint", "");
      const std::string ofp = rep0.value("options_fingerprint", "");
      if (count < 0) {
        capture_fp = cfp, options_fp = ofp;
      } else {
        if (cfp != capture_fp)
          c.fail("was fitted to another capture than " + tiles[0] +
                 " (report.capture_fingerprint " + (cfp.empty() ? "absent" : cfp) + " vs " +
                 (capture_fp.empty() ? "absent" : capture_fp) +
                 "): tiles of one merge come from one capture");
      }
      const double smooth = j.value("smooth", jsonu::json::array({0.0, 0})).at(0);
      const int sweeps = j.value("smooth", jsonu::json::array({0.0, 0})).at(1);
      if (count < 0) {
        count = n, m.w = w, m.h = h, fit = j["fit"];
        m.smooth = smooth, m.sweeps = sweeps;
        m.s_key = j.value("s_key", "s");  // what values.s holds (absent in older tiles: s)
        if (m.s_key != "s" && m.s_key != "amplitude") c.at("s_key").fail("expected s or amplitude");
        seen.assign(n, 0);
        const size_t N = static_cast<size_t>(w) * h;
        for (const auto& arr : kTexelArrays)
          if (j["values"].contains(arr.key)) (m.*arr.d).assign(arr.k * N, 0.0);
        m.pixels.assign(N, 0);
        m.determined.assign(N, 0);
        m.row0 = 0, m.row1 = h;
      }
      if (n != count || w != m.w || h != m.h)
        c.fail("tile " + std::to_string(i) + "/" + std::to_string(n) + " of a " +
               std::to_string(w) + "x" + std::to_string(h) + " grid does not belong with " +
               tiles[0]);
      if (smooth != m.smooth || sweeps != m.sweeps)
        c.at("smooth").fail("tiles of one merge must share --smooth and --smooth-sweeps");
      if (ofp != options_fp)
        c.fail("was fitted with other options than " + tiles[0] +
               " (report.options_fingerprint): tiles of one merge share every option but --tile");
      for (const char* k : {"kd", "ks", "n", "fiber_angle_deg", "model"})
        if (j["fit"].value(k, jsonu::json()) != fit.value(k, jsonu::json()))
          c.fail("its global fit differs from " + tiles[0] + " (\"" + k +
                 "\"): tiles of one merge must come from the same capture and options");
      if (i < 0 || i >= n || seen[i]++) c.at("tile").fail("tile index repeated or out of range");
      if (r0 != static_cast<int>(static_cast<long>(h) * i / n) ||
          r1 != static_cast<int>(static_cast<long>(h) * (i + 1) / n))
        c.at("rows").fail("rows do not match tile " + std::to_string(i) + " of " +
                          std::to_string(n));
      const size_t a = static_cast<size_t>(r0) * w, b = static_cast<size_t>(r1) * w;
      const jsonu::json& v = j["values"];
      for (const auto& arr : kTexelArrays) {
        if ((m.*arr.d).empty()) continue;  // s, s_sigma of a line-model fit
        const auto vals = v.at(arr.key).get<std::vector<double>>();
        if (vals.size() != arr.k * (b - a))
          c.at(std::string("values.") + arr.key).fail("wrong length");
        std::copy(vals.begin(), vals.end(), (m.*arr.d).begin() + arr.k * a);
      }
      const auto px = v.at("pixels").get<std::vector<int>>();
      const auto det = v.at("determined").get<std::vector<int>>();
      if (px.size() != b - a || det.size() != b - a) c.at("values").fail("wrong length");
      std::copy(px.begin(), px.end(), m.pixels.begin() + a);
      std::copy(det.begin(), det.end(), m.determined.begin() + a);
      m.fitted += j.at("fitted").get<size_t>();
      m.not_converged += j.value("not_converged", size_t(0));  // absent in older tiles
      m.sum_sq += j.value("sum_sq", 0.0);                      // (so too these three)
      m.values += j.value("residual_values", 0.0);
      add_orders(j.value("quadrature_orders", jsonu::json::object()), &m.texels_by_order);
      iterations = j.value("maps_iterations", 0);
      const jsonu::json tr = j["fit"].value("report", jsonu::json::object());
      noise.push_back(tr.value("pixel_noise", 0.0));
      if (tile_time.empty()) tile_time.assign(n, 0.0);
      tile_time[i] = tr.value("time_s", 0.0);
      const jsonu::json breakdown = tr.value("time_breakdown_s", jsonu::json::object());
      for (const auto& [k, v] : breakdown.items())
        if (v.is_number()) phases[k] = phases.value(k, 0.0) + v.get<double>();
      own_counts = own_counts && tr.contains("global_from");
      for (const char* k : {"pixels", "observations"})
        counts[k] = counts[k].get<size_t>() + tr.value(k, size_t(0));
      for (const char* k : {"saturated", "nonfinite", "unlit", "implausible"})
        counts[k] = counts[k].get<size_t>() +
                    tr.value("skipped", jsonu::json::object()).value(k, size_t(0));
    } catch (const jsonu::json::exception& e) {
      throw Error(path + ": not a readable tile: " + e.what());
    }
  for (int i = 0; i < count; ++i)
    if (!seen[i])
      throw Error("merge: tile " + std::to_string(i) + " of " + std::to_string(count) +
                  " is missing: give every tile's file");
  fit["report"]["merged_from_tiles"] = count;
  fit["report"]["tile_time_s"] = tile_time;
  fit["report"]["time_s"] = std::accumulate(tile_time.begin(), tile_time.end(), 0.0);
  fit["report"]["time_breakdown_s"] = phases;
  if (own_counts) {
    for (const char* k : {"pixels", "observations"}) fit["report"][k] = counts[k];
    for (const char* k : {"saturated", "nonfinite", "unlit", "implausible"})
      fit["report"]["skipped"][k] = counts[k];
    fit["report"]["skipped"].erase("outside_tile");  // each tile's: the others' rows
  }
  // The maps' warnings over the whole grid (tile 0's fit named its own rows' counts), the noise
  // the tiles' median measure (each measured the rows it read).
  m.rms = m.values > 0 ? std::sqrt(m.sum_sq / m.values) : 0;
  std::nth_element(noise.begin(), noise.begin() + noise.size() / 2, noise.end());
  FitReport rep;
  rep.rms = fit["report"].value("residual_rms", 0.0);
  for (const auto& w : warnings_read_back(fit["report"]))
    if (w.about != WarningAbout::kMaps) rep.warnings.push_back(w);
  add_maps_warnings(m, noise[noise.size() / 2], iterations, &rep);
  put_warnings(rep.warnings, &fit["report"]);
  fit["report"].erase("notes");  // each tile's named its own rows
  if (!rep.notes.empty()) fit["report"]["notes"] = rep.notes;
  fit["report"]["maps_misfit_texels"] = rep.maps_misfit_texels;
  if (fit["report"].contains("fiber_order"))
    fit["report"]["maps_quadrature_orders"] = orders_json(m.texels_by_order);
  // A topology map's path is relative to the file that names it: the tile's folder then, the
  // merged material's now.
  if (fit.contains("topology") && fit["topology"].contains("map") &&
      fit["topology"]["map"].is_string())
    fit["topology"]["map"] =
        relative_to(join_path(parent_dir(tiles[0]), fit["topology"]["map"].get<std::string>()),
                    parent_dir(out));
  put_maps_means(m, &fit);
  write_material(out, &fit, [&](const std::string& dir) { add_maps(out, dir, m, &fit, maps); });
}

}  // namespace aniso
