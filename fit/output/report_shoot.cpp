#include "fit/output/report_shoot.h"

#include <cmath>
#include <tuple>

#include "core/error.h"

namespace aniso {

jsonu::json lamps_from_highlight_json(const FitReport::LampsFromHighlight& h) {
  jsonu::json lamps = jsonu::json::array();
  auto v3 = [](const double* v) { return jsonu::json::array({v[0], v[1], v[2]}); };
  for (const auto& l : h.lamps)
    lamps.push_back({{"view", l.view},
                     {"light", l.light},
                     {"given_m", v3(l.given)},
                     {"given_sigma_m", v3(l.prior_sigma_m)},
                     {"given_sigma_stated", l.stated},
                     {"found_m", v3(l.found)},
                     {"found_sigma_m", v3(l.sigma_m)},
                     {"moved_sigmas", l.moved_sigmas},
                     {"prior_released", l.released},
                     {"pixels", l.pixels}});
  jsonu::json j = {{"used", h.used},
                   {"mode", !h.from_global.empty() ? "global"
                            : h.by_default         ? "auto"
                                                   : "always"},
                   {"lamps", lamps},
                   {"pixels", h.pixels},
                   {"views_left_out", h.views_left_out},
                   {"pixel_sigma", h.pixel_sigma},
                   {"iterations", h.iterations},
                   {"lamp_sigma_scale", h.lamp_sigma_scale},
                   {"time_s", h.seconds}};
  if (!h.jackknife_sigma.empty()) {
    const auto& s = h.jackknife_sigma;
    j["jackknife"] = {{"views", h.jackknife_views},
                      {"kd", {s[0], s[1], s[2]}},
                      {"ks", {s[3], s[4], s[5]}},
                      {"n", s[6]},
                      {"fiber_angle_deg", s[7]}};
  }
  if (!h.skipped.empty()) j["skipped"] = h.skipped;
  if (!h.from_global.empty()) j["from_global"] = h.from_global;
  return j;
}

jsonu::json psi_from_symmetry_json(const FitReport::PsiFromSymmetry& p) {
  jsonu::json j = {{"mode", p.mode}, {"ran", p.ran}, {"used", p.used}, {"why", p.why}};
  if (!p.ran) return j;
  j["fiber_angle_deg"] = p.psi_deg;
  j["sigma_deg"] = p.sigma_deg;
  j["model_fiber_angle_deg"] = p.model_psi_deg;
  // The line model's own sigma; null where it left psi undetermined.
  j["model_sigma_deg"] = p.model_sigma_deg >= 0 ? jsonu::json(p.model_sigma_deg) : jsonu::json();
  j["relative_rms"] = p.relative_rms;
  j["views"] = p.views;
  j["pixels"] = p.pixels;
  j["jackknife_fiber_angle_deg"] = p.jackknife_psi_deg;
  j["time_s"] = p.seconds;
  if (!p.why_not.empty()) j["why_not"] = p.why_not;
  return j;
}

std::vector<LampPlaced> lamps_placed_read_back(const jsonu::json& report, const std::string& file) {
  std::vector<LampPlaced> out;
  if (!report.contains("lamps_from_highlight")) return out;
  const jsonu::json& h = report["lamps_from_highlight"];
  if (!h.is_object() || !h.value("used", false)) return out;
  const auto bad = [&](const std::string& what) {
    return Error(file + ": report.lamps_from_highlight.lamps: " + what);
  };
  if (!h.contains("lamps") || !h["lamps"].is_array()) throw bad("missing or not an array");
  for (const auto& l : h["lamps"]) {
    LampPlaced p;
    if (!l.is_object() || !l.contains("view") || !l["view"].is_number_unsigned() ||
        !l.contains("light") || !l["light"].is_number_unsigned())
      throw bad("each lamp needs its view and light (whole numbers)");
    p.view = l["view"].get<size_t>(), p.light = l["light"].get<size_t>();
    // found_m and found_sigma_m are what a fit under these lamps needs; the rest is kept as read.
    const std::tuple<const char*, double*, bool> v3[] = {{"found_m", p.found, true},
                                                         {"found_sigma_m", p.sigma_m, true},
                                                         {"given_m", p.given, false},
                                                         {"given_sigma_m", p.prior_sigma_m, false}};
    for (const auto& [key, to, needed] : v3) {
      if (!needed && !l.contains(key)) continue;
      if (!l.contains(key) || !l[key].is_array() || l[key].size() != 3)
        throw bad(std::string(key) + " must be three numbers");
      for (int k = 0; k < 3; ++k) {
        if (!l[key][k].is_number()) throw bad(std::string(key) + " must be three numbers");
        to[k] = l[key][k].get<double>();
        if (!std::isfinite(to[k])) throw bad(std::string(key) + " must be finite");
      }
    }
    p.stated = l.value("given_sigma_stated", false);
    p.moved_sigmas = l.value("moved_sigmas", 0.0);
    p.released = l.value("prior_released", false);
    p.pixels = l.value("pixels", size_t(0));
    out.push_back(p);
  }
  return out;
}

}  // namespace aniso
