#include "fit/output/report_shoot.h"

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
                   {"mode", h.by_default ? "auto" : "always"},
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

}  // namespace aniso
