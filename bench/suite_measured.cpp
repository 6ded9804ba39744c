// `aniso bench measured`: every model variant fitted to each RGL material-database file of
// tests/data/rgl against libbsdf's `lbfit` on the same file in the same run (its four models:
// Unreal Engine 4, GGX, anisotropic GGX, Lambertian). lbfit is not a Debian package: it is run
// where ANISO_LBFIT names it or `lbfit` is on the PATH, and the entry says so where it is not.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "bench/bench_util.h"
#include "core/shell.h"
#include "fit/fit.h"
#include "io/formats/rgl_bsdf.h"
#include "io/formats/table.h"

namespace aniso::benchutil {

namespace {

// lbfit's path: ANISO_LBFIT, else `lbfit` on the PATH, else "".
std::string find_lbfit() {
  if (const char* p = std::getenv("ANISO_LBFIT"); p && *p) return p;
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  for (size_t a = 0; a <= dirs.size();) {
    const size_t b = std::min(dirs.find(':', a), dirs.size());
    const std::string f = dirs.substr(a, b - a) + "/lbfit";
    if (b > a && ::access(f.c_str(), X_OK) == 0) return f;
    a = b + 1;
  }
  return "";
}

// Runs lbfit on `file`: its wall time, and the "Error:" figure it prints per model (its own
// measure: the mean difference on its specular-coordinates grid, not our relative RMS).
bool run_lbfit(const std::string& lbfit, const std::string& file, double* seconds,
               std::vector<double>* errors, std::string* printed) {
  const auto t0 = Clock::now();
  std::string& out = *printed;
  const int status = run_shell(shell_quoted(lbfit) + " " + shell_quoted(file), &out);
  *seconds = since(t0);
  for (size_t at = out.find("Error: "); at != std::string::npos; at = out.find("Error: ", at + 1))
    errors->push_back(std::atof(out.c_str() + at + 7));
  return status == 0;
}

// lbfit's four fitted models as it prints them (its reflectance models in libbsdf's
// ReflectanceModel/: UnrealEngine4, SimpleGgx, SimpleAnisotropicGgx, Lambertian), evaluated here
// as f_r cos(theta_L) at a table's directions so that its fits are measured as ours are. lbfit
// fits each in log10 of f_r, so the median reading's relative error is the fairer of the two
// measures to it. Checked once against libbsdf's own getBrdfValue (built beside lbfit) at three
// direction pairs: the same to 9 digits for all four.
struct LbfitModel {
  std::string name;
  double color[3] = {0, 0, 0}, metallic = 0, specular = 0, rough = 0, rough_x = 0, rough_y = 0;
};

std::vector<LbfitModel> parse_lbfit(const std::string& out) {
  std::vector<LbfitModel> models;
  size_t at = 0;
  while ((at = out.find('[', at)) != std::string::npos) {
    const size_t end = out.find(']', at);
    if (end == std::string::npos) break;
    LbfitModel m;
    m.name = out.substr(at + 1, end - at - 1);
    const size_t next = out.find("\n[", end);
    const std::string body =
        out.substr(end, next == std::string::npos ? std::string::npos : next - end);
    auto number = [&](const char* key, double* v, int count) {
      const size_t k = body.find(std::string(key) + ": ");
      if (k == std::string::npos) return;
      std::istringstream in(body.substr(k + std::strlen(key) + 2));
      for (int i = 0; i < count; ++i) in >> v[i];
    };
    number("Base color", m.color, 3);
    number("Color", m.color, 3);
    number("Metallic", &m.metallic, 1);
    number("Specular", &m.specular, 1);
    number("Roughness", &m.rough, 1);
    number("Roughness X", &m.rough_x, 1);
    number("Roughness Y", &m.rough_y, 1);
    models.push_back(m);
    at = end;
  }
  return models;
}

// f_r of one of lbfit's models at light L and view V (normal z, tangent x, binormal -y), as
// libbsdf computes it.
void lbfit_brdf(const LbfitModel& m, const LocalDir& L, const LocalDir& V, double f[3]) {
  const double nl = L.n, nv = V.n;
  double h[3] = {L.u + V.u, L.w + V.w, L.n + V.n};
  const double hl = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
  for (double& x : h) x /= hl;
  const double nh = h[2], lh = std::clamp(L.u * h[0] + L.w * h[1] + L.n * h[2], -1.0, 1.0);
  auto g1 = [](double dot, double sq_alpha) {
    return 2 / (1 + std::sqrt(1 + sq_alpha * (1 / (dot * dot) - 1)));
  };
  for (int c = 0; c < 3; ++c) f[c] = 0;
  if (m.name == "Lambertian") {
    for (int c = 0; c < 3; ++c) f[c] = m.color[c] / M_PI;
  } else if (m.name.rfind("GGX (isotropic", 0) == 0 || m.name.rfind("GGX (anisotropic", 0) == 0) {
    const bool aniso = m.name.rfind("GGX (anisotropic", 0) == 0;
    const double ax = aniso ? m.rough_x * m.rough_x : m.rough * m.rough;
    const double ay = aniso ? m.rough_y * m.rough_y : ax;
    const double sq = ax * ay;
    const double G = g1(nl, sq) * g1(nv, sq);
    double D;
    if (aniso) {
      const double th = h[0], bh = -h[1];
      const double d = th * th / (ax * ax) + bh * bh / (ay * ay) + nh * nh;
      D = 1 / (M_PI * sq * d * d);
    } else {
      const double d = nh * nh * (sq - 1) + 1;
      D = sq / (M_PI * d * d);
    }
    for (int c = 0; c < 3; ++c) {
      const double F = m.color[c] + (1 - m.color[c]) * std::pow(1 - lh, 5);
      f[c] = F * G * D / (4 * nl * nv);
    }
  } else if (m.name == "Unreal Engine 4") {
    const double alpha = m.rough * m.rough, sq = alpha * alpha;
    const double vh = V.u * h[0] + V.w * h[1] + V.n * h[2];
    const double d = nh * nh * (sq - 1) + 1, D = sq / (M_PI * d * d);
    const double gv = nl * (nv * (1 - alpha) + alpha), gl = nv * (nl * (1 - alpha) + alpha);
    const double vis = 0.5 / (gv + gl), fc = std::pow(1 - vh, 5);
    double f0[3];
    for (int c = 0; c < 3; ++c)
      f0[c] = 0.08 * m.specular + (m.color[c] - 0.08 * m.specular) * m.metallic;
    const double clamped = std::min(50 * f0[1], 1.0) * fc;
    for (int c = 0; c < 3; ++c)
      f[c] = m.color[c] / M_PI * (1 - m.metallic) + (clamped + (1 - fc) * f0[c]) * D * vis;
  }
}

// Each of lbfit's models against the readings, on our measures.
json lbfit_misfits(const std::vector<LbfitModel>& models, const SampleTable& readings) {
  json out = json::array();
  for (const LbfitModel& m : models) {
    SampleTable t = readings;
    for (SampleRow& row : t.rows) {
      const LocalDir L = dir_from_angles(row.theta_i, row.phi_i);
      const LocalDir V = dir_from_angles(row.theta_o, row.phi_o);
      double f[3];
      lbfit_brdf(m, L, V, f);
      for (int c = 0; c < 3; ++c) row.value[c] = L.n > 0 && V.n > 0 ? f[c] * L.n : 0.0;
    }
    const TableMisfit e = table_misfit(t, readings);
    out.push_back({{"model", m.name},
                   {"relative_rms", e.relative_rms},
                   {"median_relative", e.median_relative}});
  }
  return out;
}

}  // namespace

json bench_measured(bool quick) {
  json out = json::array();
  const std::string data = std::string(ANISO_SOURCE_DIR) + "/tests/data/rgl/";
  const std::string lbfit = quick ? "" : find_lbfit();
  if (lbfit.empty() && !quick)
    std::printf(
        "bench measured: WARNING: lbfit (libbsdf, cmake -DLIBBSDF_ENABLE_FITTING=ON) not found: "
        "set ANISO_LBFIT or put it on the PATH; the entries have no baseline\n");
  for (const char* name : {"paper_white_rgb.bsdf", "satin_rosaline_rgb.bsdf"}) {
    const std::string file = data + name;
    struct Variant {
      const char* what;
      FitModel model;
      bool iso;
    };
    const Variant variants[] = {{"line", FitModel::kLine, false},
                                {"line --fit-isotropic", FitModel::kLine, true},
                                {"fiber", FitModel::kFiber, false}};
    json per = json::array();
    const auto t0 = Clock::now();
    const RglBsdf b = RglBsdf::read(file);
    const SampleTable table = measured_table(b);
    for (const Variant& v : variants) {
      FitOptions o;
      o.progress = nullptr;
      o.model = v.model;
      o.fit_isotropic = v.iso;
      const auto t1 = Clock::now();
      const FitResult r = fit_table(table, o);
      const double seconds = since(t1);
      const TableMisfit e = table_misfit(r.material, table);
      per.push_back(
          {{"variant", v.what},
           {"seconds", seconds},
           {"relative_rms", e.relative_rms},
           {"median_relative", e.median_relative},
           {"written", r.report.anisotropy.isotropic_written ? "isotropic part alone"
                                                             : model_name(r.material.model)}});
    }
    const double ours = since(t0);
    double base = NAN;
    std::vector<double> lb_errors;
    std::string note, printed;
    if (!lbfit.empty() && !run_lbfit(lbfit, file, &base, &lb_errors, &printed)) {
      note = lbfit + " failed on " + file;
      base = NAN;
    }
    const std::vector<LbfitModel> lb_models = parse_lbfit(printed);
    json e = entry("measured",
                   std::string("every model variant fitted to ") + name +
                       " (read, sample, fit) vs libbsdf's lbfit (its four models)",
                   ours, base, "s", NAN);
    e["ratio_definition"] = "baseline / ours";
    e["variants"] = per;
    e["readings"] = table.rows.size();
    if (!lb_errors.empty()) {
      e["lbfit_errors"] = lb_errors;
      e["lbfit_error_note"] =
          "lbfit's own measure (mean difference on its specular-coordinates grid; UE4, GGX, "
          "anisotropic GGX, Lambertian), not comparable with relative_rms";
    }
    // Both tools' fits on the same readings and measures: the best variant of each.
    auto best = [](const json& list, const char* key) {
      double b = HUGE_VAL;
      for (const auto& v : list) b = std::min(b, v[key].get<double>());
      return b;
    };
    if (lb_models.size() == 4) {
      const json lb = lbfit_misfits(lb_models, table);
      e["lbfit_models"] = lb;
      e["error_no_worse"] = {
          {"relative_rms",
           {{"ours", best(per, "relative_rms")}, {"lbfit", best(lb, "relative_rms")}}},
          {"median_relative",
           {{"ours", best(per, "median_relative")}, {"lbfit", best(lb, "median_relative")}}},
          {"met", best(per, "relative_rms") <= best(lb, "relative_rms") &&
                      best(per, "median_relative") <= best(lb, "median_relative")}};
      std::printf(
          "bench measured: %s: best relative RMS ours %.3f, lbfit %.3f; median reading's "
          "relative error ours %.3f, lbfit %.3f\n",
          name, best(per, "relative_rms"), best(lb, "relative_rms"), best(per, "median_relative"),
          best(lb, "median_relative"));
      for (const auto& m : lb)
        std::printf("bench measured:   lbfit %s: relative RMS %.3f, median %.3f\n",
                    m["model"].get<std::string>().c_str(), m["relative_rms"].get<double>(),
                    m["median_relative"].get<double>());
    }
    // The target was set as 1/20 of the 41-95 s lbfit took a file where it was set: 2 s. lbfit
    // runs faster on other machines (10-15 s on the 2-core one of BENCHMARKS.md), so the ratio of
    // this run is recorded beside it, with whether it reaches 20.
    target(&e, "<= 2 s a file (1/20 of lbfit's 41-95 s where the target was set)", ours <= 2.0,
           "every variant took longer than 2 s");
    if (std::isfinite(base))
      e["ratio_at_least_20"] = base / ours >= 20;
    else
      e["baseline_note"] = note.empty() ? "lbfit not found: no baseline in this run" : note;
    std::printf("bench measured: %s: every variant %.3f s (", name, ours);
    for (const auto& v : per)
      std::printf("%s %.3f s rel. RMS %.3f; ", v["variant"].get<std::string>().c_str(),
                  v["seconds"].get<double>(), v["relative_rms"].get<double>());
    if (std::isfinite(base))
      std::printf("), lbfit %.1f s, ratio %.0f\n", base, base / ours);
    else
      std::printf("), no lbfit\n");
    out.push_back(e);
  }
  return out;
}

}  // namespace aniso::benchutil
