// `aniso bench measured`: every model variant fitted to each RGL material-database file of
// tests/data/rgl against libbsdf's `lbfit` on the same file in the same run (its four models:
// Unreal Engine 4, GGX, anisotropic GGX, Lambertian). lbfit is not a Debian package: it is run
// where ANISO_LBFIT names it or `lbfit` is on the PATH, and the entry says so where it is not.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
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
               std::vector<double>* errors) {
  const auto t0 = Clock::now();
  std::string out;
  const int status = run_shell(shell_quoted(lbfit) + " " + shell_quoted(file), &out);
  *seconds = since(t0);
  for (size_t at = out.find("Error: "); at != std::string::npos; at = out.find("Error: ", at + 1))
    errors->push_back(std::atof(out.c_str() + at + 7));
  return status == 0;
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
      o.progress = false;
      o.model = v.model;
      o.fit_isotropic = v.iso;
      const auto t1 = Clock::now();
      const FitResult r = fit_table(table, o);
      per.push_back(
          {{"variant", v.what},
           {"seconds", since(t1)},
           {"relative_rms", table_misfit(r.material, table).relative_rms},
           {"written", r.report.anisotropy.isotropic_written ? "isotropic part alone"
                                                             : model_name(r.material.model)}});
    }
    const double ours = since(t0);
    double base = NAN;
    std::vector<double> lb_errors;
    std::string note;
    if (!lbfit.empty() && !run_lbfit(lbfit, file, &base, &lb_errors)) {
      note = lbfit + " failed on " + file;
      base = NAN;
    }
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
