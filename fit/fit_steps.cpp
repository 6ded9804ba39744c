// A photo shoot's steps around the fit (fit/fit_steps.h): the lamps placed by the sample's
// highlight (fit/lamps), the fiber direction from the highlight's symmetry
// (fit/global/psi_symmetry.h).
#include "fit/fit_steps.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "core/error.h"
#include "core/progress.h"
#include "core/timer.h"
#include "fit/global/psi_symmetry.h"
#include "fit/lamps/highlight_lamps.h"

namespace aniso {

using namespace fitting;

namespace {

using Clock = SteadyClock;

bool misses_the_data(const FitResult& r) {
  for (const Warning& w : r.report.warnings)
    if (w.about == WarningAbout::kGlobalMisfit) return true;
  return false;
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

// The lamps as the report holds them.
std::vector<LampPlaced> lamps_placed(const HighlightLamps& hl) {
  std::vector<LampPlaced> out;
  for (const HighlightLamp& h : hl.lamps) {
    LampPlaced p;
    p.view = h.view, p.light = h.light, p.stated = h.stated, p.pixels = h.pixels;
    p.moved_sigmas = h.moved_sigmas;
    p.released = h.released;
    const Vec3* from[4] = {&h.given, &h.prior_sigma_m, &h.found, &h.sigma_m};
    double* to[4] = {p.given, p.prior_sigma_m, p.found, p.sigma_m};
    for (int a = 0; a < 4; ++a) to[a][0] = from[a]->x, to[a][1] = from[a]->y, to[a][2] = from[a]->z;
    out.push_back(p);
  }
  return out;
}

// The lamps placed by the highlight and the fit under them, or under the lamps as given where they
// were not placed (hl.skipped says why).
struct PlacedLamps {
  HighlightLamps hl;
  CaptureSet lit;  // the capture the fit was made under
  FitResult fit;
};

// --lamps-from-highlight: the line model fitted under the lamps as given, its material and every
// point lamp fitted together (fit/lamps/highlight_lamps.h), then the fit asked for under the lamps
// found, their sigma as the problem gave it. What it did goes into the report by say_lamps.
PlacedLamps place_lamps(const CaptureSet& set, const FitOptions& opt) {
  if (opt.global || opt.tile_count > 0)
    throw Error(
        "fit: --lamps-from-highlight places the lamps with the global fit: leave out --global and "
        "--tile (fit the global values with it, then give that material to --global)");
  if (opt.model != FitModel::kLine)
    throw Error(
        "fit: --lamps-from-highlight places the lamps with the line model: give --model line");
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
  // Where the model misses the data even under the lamps found and the typical lamp moved more
  // than kTypicalLampMovedSigmas, the highlight has moved them to take up the misfit, not to where
  // the lamps are (on shoots rendered with a BRDF the line model does not have they went 8-14 cm
  // astray, 4-7 sigmas the median): the fit is made under the lamps as given, and the lamps'
  // jackknife is not run. One or two lamps far off with the rest in place is what the highlight is
  // there to find. The fit under the lamps found that decides it is the one kept where they stay
  // (their sigma, set after, does not enter a fit).
  constexpr double kTypicalLampMovedSigmas = 3;
  std::optional<FitResult> under_found;
  const auto keep = [&](const HighlightLamps& hl) -> std::string {
    std::vector<double> moved;
    for (const HighlightLamp& h : hl.lamps) moved.push_back(h.moved_sigmas);
    std::nth_element(moved.begin(), moved.begin() + moved.size() / 2, moved.end());
    const double typical = moved.empty() ? 0 : moved[moved.size() / 2];
    if (!(typical > kTypicalLampMovedSigmas)) return "";
    under_found = fit_capture_here(with_lamps_placed(set, lamps_placed(hl), set.file), rest);
    if (!misses_the_data(*under_found)) return "";
    const FitReport& u = under_found->report;
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "under the lamps the highlight found the model still misses the data (residual "
                  "RMS %.3g, %.1fx the images' noise) and the typical lamp moved %.1f of its "
                  "sigmas: the highlight would place the lamps where they take up the model's "
                  "misfit",
                  u.rms, u.rms / std::max(u.pixel_noise, 1e-300), typical);
    return buf;
  };
  PlacedLamps s{lamps_from_highlight(set, first.material, sigma, opt.threads, keep), set, {}};
  if (opt.progress) opt.progress->status("");
  if (s.hl.skipped.empty()) s.lit = with_lamps_placed(set, lamps_placed(s.hl), set.file);
  s.fit =
      s.hl.skipped.empty() && under_found ? std::move(*under_found) : fit_capture_here(s.lit, rest);
  return s;
}

// What place_lamps did, in the report of the fit `r` made from it (the fiber direction from the
// symmetry perhaps taken since): report.lamps_from_highlight, each sigma at least the lamps'
// jackknife's, a lamp moved past kLampMovedSigmas named, how far they moved.
void say_lamps(const PlacedLamps& s, const CaptureSet& set, const FitOptions& opt, FitResult* r) {
  const HighlightLamps& hl = s.hl;
  FitReport::LampsFromHighlight& out = r->report.lamps_from_highlight;
  out.asked = true;
  out.by_default = opt.lamps_from_highlight == LampsFromHighlight::kAuto;
  out.used = hl.skipped.empty();
  out.skipped = hl.skipped;
  // Asked for, a lamp not placed is a warning; by default, what the fit would have done anyway.
  if (!out.used) {
    const std::string kept =
        "--lamps-from-highlight: the lamps are kept as " + set.file + " gives them: " + hl.skipped;
    if (out.by_default)
      r->report.notes.push_back(kept);
    else
      r->report.warnings.push_back(kept);
  }
  out.pixels = hl.pixels;
  out.views_left_out = hl.views_left_out;
  out.pixel_sigma = hl.pixel_sigma;
  out.iterations = hl.iterations;
  out.seconds = hl.seconds;
  out.jackknife_sigma = hl.jackknife_sigma;
  out.jackknife_views = hl.jackknife_views;
  out.lamp_sigma_scale = hl.lamp_sigma_scale;
  out.lamps = lamps_placed(hl);
  // The lamps were fitted to the same pixels: the views' own residuals, which the whole sigma is
  // the spread of, no longer show the lamps' errors (the lamps took them). Each sigma is at least
  // the jackknife's (a --maps fit's scalars are the maps' means, whose sigma is the texels'; a psi
  // from the symmetry has its own jackknife's).
  if (out.used && !hl.jackknife_sigma.empty() && opt.maps_w == 0) {
    const bool own_psi = !r->report.psi_from_symmetry.used;
    const std::pair<const char*, int> at[] = {
        {"kd", 0}, {"ks", 3}, {"n", 6}, {"fiber_angle_deg", 7}};
    for (const auto& [key, k0] : at) {
      auto it = r->sigma.find(key);
      if (it == r->sigma.end() || (k0 == 7 && !own_psi)) continue;
      for (size_t i = 0; i < it->second.size(); ++i)
        it->second[i] = std::max(it->second[i], hl.jackknife_sigma[k0 + i]);
    }
    r->uncertainty_basis +=
        "; with the lamps placed by the highlight, at least the spread of a "
        "jackknife over the " +
        std::to_string(hl.jackknife_views) + " views of the lamps' and the material's joint fit";
  }
  if (!out.used || hl.lamps.empty()) return;
  for (const HighlightLamp& h : hl.lamps) {
    if (!(h.moved_sigmas > kLampMovedSigmas)) continue;
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
    r->report.warnings.push_back(std::string(buf));
  }
  std::vector<double> mm;
  for (const HighlightLamp& h : hl.lamps) mm.push_back(1e3 * length(h.found - h.given));
  std::sort(mm.begin(), mm.end());
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "the %zu lamps placed again by the sample's highlight together with the "
                "material: moved %.1f mm (median), at most %.0f mm, from where %s puts them%s",
                mm.size(), mm[mm.size() / 2], mm.back(), set.file.c_str(),
                out.by_default ? " (--lamps-as-imported fits under them as given)" : "");
  r->report.notes.push_back(buf);
}

// The fiber direction from the highlight's symmetry (fit/global/psi_symmetry.h) for the line
// model's global fit: by default where that model misses the data (a lobe of another shape: its
// own psi is then the one its shape fits best, uncertain by degrees), taken where its jackknife's
// sigma is smaller than the model's own and the two agree within 3 of their sigmas; the other
// numbers are then fitted again under it. `lit`: the capture the fit `r` was made under (its lamps
// as the highlight placed them, where it did).
FitResult with_psi_from_symmetry(const CaptureSet& lit, const FitOptions& opt, FitResult r) {
  if (opt.psi_symmetry == PsiSymmetry::kNever) return r;
  const bool always = opt.psi_symmetry == PsiSymmetry::kAlways;
  FitReport::PsiFromSymmetry rep;
  rep.mode = psi_symmetry_name(opt.psi_symmetry);
  const auto keep = [&](std::string why) {
    rep.why = std::move(why);
    r.report.psi_from_symmetry = rep;
    return std::move(r);
  };
  if (r.material.model != Model::kLine || r.material.has_second_fiber)
    return keep("the line model with one fiber direction only");
  if (opt.maps_w > 0 || opt.global || opt.tile_count > 0)
    return keep("the global fit only (a --maps fit has each texel's own psi)");
  const bool misfit = misses_the_data(r);
  if (!misfit && !always)
    return keep("the line model describes the data (--psi-from-symmetry auto)");
  rep.ran = true;
  rep.why = misfit ? "the line model misses the data" : "asked (--psi-from-symmetry always)";
  if (opt.progress) opt.progress->status("fit: the fiber direction from the highlight's symmetry");
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
  h.report.notes.push_back(said + "; taken, the other numbers fitted under it");
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
  for (const ViewSpec& v : set.views)
    stated += v.lights.size() == 1 && inverse_square_point(v.lights[0]) &&
              position_sigma_stated(v.lights[0]);
  return stated >= kMinJackknifeViews;
}

}  // namespace

FitResult fit_capture_steps(const CaptureSet& set, const FitOptions& opt) {
  // A global fit made under lamps the highlight placed: the rest of the fit under them too.
  if (opt.global && !opt.global->lamps_placed.empty()) {
    const CaptureSet lit = with_lamps_placed(set, opt.global->lamps_placed, opt.global->file);
    FitResult r = fit_capture_here(lit, opt);
    FitReport::LampsFromHighlight& h = r.report.lamps_from_highlight;
    h.asked = h.used = true;
    h.from_global = opt.global->file;
    h.lamps = opt.global->lamps_placed;
    r.report.notes.push_back("under the " + std::to_string(opt.global->lamps_placed.size()) +
                             " lamps as the sample's highlight placed them with the global fit (" +
                             opt.global->file + ")");
    return r;
  }
  if (!places_lamps(set, opt)) return with_psi_from_symmetry(set, opt, fit_capture_here(set, opt));
  const auto t0 = Clock::now();
  PlacedLamps s = place_lamps(set, opt);
  FitResult r = with_psi_from_symmetry(s.lit, opt, std::move(s.fit));
  say_lamps(s, set, opt, &r);
  r.report.seconds = seconds_since(t0);
  return r;
}

}  // namespace aniso
