// `aniso bench fit`: the whole `aniso fit` process on the sets of the fit's speed targets, bm16 (16
// views of 128², brushed metal, 1 % noise) and bm64 (64 views of 256²): wall time and peak memory
// of the fused solver against Ceres (--solver ceres) in the same run, each a child process started
// the way a user starts it, the median of three runs. Then --maps' texel phase against one Ceres
// problem per texel, and the fiber model, fused against Ceres.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/bench_util.h"
#include "capture_sim/sim.h"
#include "core/error.h"
#include "datasets_synth/presets.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"

namespace aniso::benchutil {

namespace {

struct Run {
  double seconds = NAN;
  long max_rss_kb = 0;
  bool ok = false;
};

// The `aniso` a user runs: the lean one beside this binary (cli/commands_lean.cpp), else this one,
// run from a private copy made at the first call (the suite runs it for minutes, and a rebuild in
// the meantime timed a mix of two builds); the copy goes when this process ends.
class BinaryCopy {
 public:
  BinaryCopy() {
    const std::string lean = program_beside_self("aniso");
    std::error_code ec;
    from_ = lean.empty() ? std::filesystem::read_symlink("/proc/self/exe", ec).string() : lean;
    copy_ = (std::filesystem::temp_directory_path(ec) /
             ("aniso-bench-" + std::to_string(::getpid()) + "-" + std::to_string(stamp())))
                .string();
    if (ec || !std::filesystem::copy_file(from_, copy_, ec) || ec) copy_.clear();
  }
  ~BinaryCopy() {
    std::error_code ec;
    if (!copy_.empty()) std::filesystem::remove(copy_, ec);
  }
  // The copy, or the binary itself where no copy could be made.
  const std::string& path() const { return copy_.empty() ? from_ : copy_; }

 private:
  static unsigned stamp() { return static_cast<unsigned>(Clock::now().time_since_epoch().count()); }
  std::string from_, copy_;
};

const std::string& aniso_binary() {
  static const BinaryCopy binary;
  return binary.path();
}

// `aniso` with `args`, its wall time and peak resident memory (getrusage of the child).
Run run_self(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  std::string self = aniso_binary();
  argv.push_back(self.data());
  std::vector<std::string> copy = args;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  const auto t0 = Clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    if (!std::freopen("/dev/null", "w", stdout) || !std::freopen("/dev/null", "w", stderr))
      _exit(126);
    execv(self.c_str(), argv.data());
    _exit(127);
  }
  Run r;
  int status = 0;
  rusage ru{};
  if (pid < 0 || wait4(pid, &status, 0, &ru) != pid) return r;
  r.seconds = since(t0);
  r.max_rss_kb = ru.ru_maxrss;
  r.ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  return r;
}

// The middle of three timings; NaN unless all three ran.
double middle_of_three(std::vector<double> t) {
  std::sort(t.begin(), t.end());
  return t.size() == 3 ? t[1] : NAN;
}

Run median_of_three(const std::vector<std::string>& args) {
  std::vector<Run> runs;
  for (int i = 0; i < 3; ++i) runs.push_back(run_self(args));
  std::sort(runs.begin(), runs.end(),
            [](const Run& a, const Run& b) { return a.seconds < b.seconds; });
  Run m = runs[1];
  for (const Run& r : runs) m.ok &= r.ok, m.max_rss_kb = std::max(m.max_rss_kb, r.max_rss_kb);
  return m;
}

// The largest |a - b| / sigma_b over the fitted numbers of two material files.
double sigma_difference(const std::string& a_path, const std::string& b_path) {
  const auto a = jsonu::json::parse(read_text_file(a_path), nullptr, false);
  const auto b = jsonu::json::parse(read_text_file(b_path), nullptr, false);
  if (!a.is_object() || !b.is_object() || !b.contains("uncertainty")) return NAN;
  const auto& u = b["uncertainty"];
  double worst = 0;
  auto cmp = [&](const jsonu::json& x, const jsonu::json& y, const jsonu::json& s) {
    if (x.is_number() && y.is_number() && s.is_number() && s.get<double>() > 0)
      worst = std::max(worst, std::abs(x.get<double>() - y.get<double>()) / s.get<double>());
  };
  for (const char* k : {"kd", "ks"})
    for (int c = 0; c < 3; ++c) cmp(a[k][c], b[k][c], u[k][c]);
  for (const char* k : {"n", "fiber_angle_deg"}) cmp(a[k], b[k], u[k]);
  if (u.contains("topology"))
    for (const auto& [k, s] : u["topology"].items()) cmp(a["topology"][k], b["topology"][k], s);
  return worst;
}

// The fiber model ("the slow one"): `aniso fit --model M` on a preset, fused (median
// of three) against --solver ceres (one run: it takes minutes), and how far apart they land.
json fiber_entry(const std::string& work, bool quick, const char* preset, const char* model) {
  PresetOptions po;
  po.views = quick ? 4 : 16;
  po.width = po.height = quick ? 64 : 128;
  po.noise = 0.01;
  po.topology_s = 0.4;
  po.progress = nullptr;
  const std::string stem = join_path(work, std::string(preset) + "_" + model);
  const std::string dir = stem + "_set";
  simulate_capture(make_preset(preset, po), dir);
  const std::vector<std::string> args = {"fit", dir, "--model", model, "--out"};
  auto with = [&](std::vector<std::string> a, const std::string& out, const char* solver) {
    a.push_back(out);
    a.insert(a.end(), {"--solver", solver});
    return a;
  };
  const Run fused = median_of_three(with(args, stem + "_fused.json", "fused"));
  const Run ceres = run_self(with(args, stem + "_ceres.json", "ceres"));
  const double diff =
      fused.ok && ceres.ok ? sigma_difference(stem + "_fused.json", stem + "_ceres.json") : NAN;
  json e = entry("fit",
                 std::string("whole process: aniso fit --model ") + model + " on " + preset + " (" +
                     std::to_string(po.views) + " views of " + std::to_string(po.width) +
                     "^2), fused LM vs --solver ceres (one run)",
                 fused.seconds, ceres.seconds, "s", NAN);
  e["largest_difference_sigma"] = std::isfinite(diff) ? json(diff) : json(nullptr);
  if (!quick)
    target(&e, ">= 10x faster than Ceres at the same answer (within 0.1 sigma)",
           fused.ok && ceres.ok && ceres.seconds >= 10 * fused.seconds && diff < 0.1,
           "see BENCHMARKS.md: the fiber model");
  std::printf("bench fit: --model %s on %s: fused %.3f s, ceres %.3f s (%.1fx), %.4f sigma apart\n",
              model, preset, fused.seconds, ceres.seconds, ceres.seconds / fused.seconds, diff);
  return e;
}

// The texel phase's seconds (report.time_breakdown_s.texels) of a --maps material file.
double texel_seconds(const std::string& mat) {
  const auto j = jsonu::json::parse(read_text_file(mat), nullptr, false);
  if (!j.is_object() || !j.contains("report")) return NAN;
  return j["report"]["time_breakdown_s"].value("texels", NAN);
}

// The largest |a - b| / sigma_b over the determined texels of two --maps fits (k_d, k_s, n, psi).
// The map file STEM.json names for `key`: "kd", "kd_sigma", "determined", "coverage", ... (from
// its maps or maps_uncertainty block).
std::string map_file(const std::string& stem, std::string key) {
  const bool sigma = key.size() > 6 && key.compare(key.size() - 6, 6, "_sigma") == 0;
  if (sigma) key.resize(key.size() - 6);
  const bool uncertainty = sigma || key == "determined" || key == "coverage";
  const std::string f =
      named_map_file(stem + ".json", uncertainty ? "maps_uncertainty" : "maps", key);
  if (f.empty()) throw Error(stem + ".json: names no map " + key);
  return f;
}

double maps_difference(const std::string& a_stem, const std::string& b_stem) {
  auto img = [](const std::string& stem, const std::string& key) {
    return read_image(map_file(stem, key)).image;
  };
  const Image det = img(b_stem, "determined");
  double worst = 0;
  for (const char* key : {"kd", "ks", "n"}) {
    const Image a = img(a_stem, key), b = img(b_stem, key),
                sg = img(b_stem, std::string(key) + "_sigma");
    for (size_t i = 0; i < a.px.size(); ++i)
      if (det.px[i / a.channels] > 0.5 && sg.px[i] > 0)
        worst = std::max(worst, std::abs(double(a.px[i]) - b.px[i]) / sg.px[i]);
  }
  const Image fa = img(a_stem, "fiber"), fb = img(b_stem, "fiber"), fs = img(b_stem, "fiber_sigma");
  for (size_t t = 0; t < det.px.size(); ++t) {
    if (det.px[t] < 0.5 || !(fs.px[t] > 0)) continue;
    double d = std::abs(std::atan2(fa.px[2 * t + 1], fa.px[2 * t]) -
                        std::atan2(fb.px[2 * t + 1], fb.px[2 * t])) *
               90 / M_PI;
    d = std::min(d, 180 - d);
    worst = std::max(worst, d / fs.px[t]);
  }
  return worst;
}

// --maps: the texel phase by the hand-written LM (float lanes, then double; median of
// three) against one Ceres problem per texel (one run), both from the same --global fit of a
// swirl-brushed plate, and how far apart the maps land.
json maps_entry(const std::string& work, bool quick, int views) {
  PresetOptions po;
  po.views = quick ? 8 : views;
  po.width = po.height = quick ? 64 : 256;
  po.noise = 0.01;
  po.progress = nullptr;
  const std::string stem = join_path(work, "swirl" + std::to_string(po.views));
  const std::string dir = stem + "_set", global = stem + "_global.json";
  SimOptions swirl = make_preset("swirl-plate", po);
  swirl.compression = ExrCompression::kNone;  // what aniso synth writes by default
  simulate_capture(swirl, dir);
  const std::string grid = quick ? "8x8" : "64x64";
  // The plate as a whole shows no one direction (a swirl): --keep-anisotropic keeps the line
  // fit the texels start from, as the isotropic part alone would be refused as --global.
  run_self({"fit", dir, "--subsample", "4", "--keep-anisotropic", "--out", global});
  auto maps = [&](const char* solver) {
    return std::vector<std::string>{"fit",           dir,
                                    "--maps",        grid,
                                    "--global",      global,
                                    "--maps-solver", solver,
                                    "--out",         stem + "_" + solver + ".json"};
  };
  std::vector<double> lm;
  for (int i = 0; i < 3; ++i)
    if (run_self(maps("lm")).ok) lm.push_back(texel_seconds(stem + "_lm.json"));
  const double ours = middle_of_three(lm);
  const bool ceres_ok = run_self(maps("ceres")).ok;
  const double ceres = ceres_ok ? texel_seconds(stem + "_ceres.json") : NAN;
  const double diff =
      ceres_ok && std::isfinite(ours) ? maps_difference(stem + "_lm", stem + "_ceres") : NAN;
  json e = entry("fit",
                 "--maps " + grid + " texel phase on swirl-plate (" + std::to_string(po.views) +
                     " views of " + std::to_string(po.width) +
                     "^2), LM per texel vs one Ceres problem per texel",
                 ours, ceres, "s", NAN);
  e["largest_difference_sigma"] = std::isfinite(diff) ? json(diff) : json(nullptr);
  if (!quick)
    target(&e, ">= 30x the per-texel Ceres baseline at the same answer (within 0.1 sigma)",
           ceres >= 30 * ours && diff < 0.1, "see BENCHMARKS.md: maps");
  std::printf("bench fit: --maps %s, %d views: LM %.3f s, Ceres %.3f s (%.1fx), %.4f sigma apart\n",
              grid.c_str(), po.views, ours, ceres, ceres / ours, diff);
  return e;
}

// The texel phase at the CPU's widest float lanes (16 with AVX-512) against eight (--maps-lanes
// 8, AVX2: what a CPU without AVX-512 runs), on maps_entry's set and global fit (made there
// first), alternated three times each (medians), and how far apart the maps land.
json lanes_entry(const std::string& work, bool quick, int views) {
  const std::string stem = join_path(work, "swirl" + std::to_string(quick ? 8 : views));
  const std::string dir = stem + "_set", global = stem + "_global.json";
  const std::string grid = quick ? "8x8" : "64x64";
  std::vector<double> t[2];
  int lanes[2] = {0, 0};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 2; ++k) {
      const std::string out = stem + (k == 0 ? "_widest.json" : "_eight.json");
      std::vector<std::string> a = {"fit", dir, "--maps", grid, "--global", global, "--out", out};
      if (k == 1) a.insert(a.end(), {"--maps-lanes", "8"});
      if (!run_self(a).ok) continue;
      t[k].push_back(texel_seconds(out));
      const auto j = jsonu::json::parse(read_text_file(out), nullptr, false);
      if (j.is_object()) lanes[k] = j["report"].value("maps_float_lanes", 0);
    }
  const double ours = middle_of_three(t[0]), eight = middle_of_three(t[1]);
  const double diff = std::isfinite(ours) && std::isfinite(eight)
                          ? maps_difference(stem + "_widest", stem + "_eight")
                          : NAN;
  json e = entry("fit",
                 "--maps " + grid + " texel phase on swirl-plate (" +
                     std::to_string(quick ? 8 : views) + " views), " + std::to_string(lanes[0]) +
                     " float lanes (the CPU's widest) vs 8 (--maps-lanes 8)",
                 ours, eight, "s", NAN);
  e["lanes"] = lanes[0];
  e["largest_difference_sigma"] = std::isfinite(diff) ? json(diff) : json(nullptr);
  std::printf(
      "bench fit: --maps %s, %d float lanes %.3f s against 8 lanes %.3f s (%.2fx), %.4f "
      "sigma apart\n",
      grid.c_str(), lanes[0], ours, eight, eight / ours, diff);
  return e;
}

// --maps with --global band by band (--maps-memory at an eighth of the records) against one band,
// on maps_entry's set and global fit (made there first): the whole process and its peak memory
// (median of three each), and whether the maps are the same bytes.
json bands_entry(const std::string& work, bool quick, int views) {
  const std::string stem = join_path(work, "swirl" + std::to_string(quick ? 8 : views));
  const std::string dir = stem + "_set", global = stem + "_global.json";
  const std::string grid = quick ? "8x8" : "64x64";
  auto fit = [&](const std::string& out, const std::string& memory) {
    std::vector<std::string> a = {"fit", dir, "--maps", grid, "--global", global, "--out", out};
    if (!memory.empty()) a.insert(a.end(), {"--maps-memory", memory});
    return median_of_three(a);
  };
  const Run one = fit(stem + "_one.json", "");
  double records_mb = NAN;
  int bands = 0;
  if (one.ok) {
    const auto j = jsonu::json::parse(read_text_file(stem + "_one.json"), nullptr, false);
    records_mb = 60e-6 * j["report"].value("pixels", 0.0);  // 60 bytes a pixel and light
  }
  const std::string memory = std::to_string(std::max(0.001, records_mb / 8));
  const Run banded = fit(stem + "_bands.json", memory);
  bool same = one.ok && banded.ok;
  if (banded.ok) {
    const auto j = jsonu::json::parse(read_text_file(stem + "_bands.json"), nullptr, false);
    bands = j["report"].value("maps_bands", 0);
    for (const char* k : {"kd", "ks", "n", "fiber", "kd_sigma", "ks_sigma", "n_sigma",
                          "fiber_sigma", "coverage", "determined"})
      same = same && read_text_file(map_file(stem + "_one", k)) ==
                         read_text_file(map_file(stem + "_bands", k));
  }
  json e = entry("fit",
                 "whole process: fit --maps " + grid + " --global on swirl-plate (" +
                     std::to_string(quick ? 8 : views) + " views), in " + std::to_string(bands) +
                     " bands of texel rows (--maps-memory an eighth of the records) vs one band",
                 banded.seconds, one.seconds, "s", NAN);
  e["peak_rss_kb"] = {{"bands", banded.max_rss_kb}, {"one_band", one.max_rss_kb}};
  e["records_mb"] = records_mb;
  e["maps_identical"] = same;
  std::printf(
      "bench fit: --maps %s --global in %d bands: %.3f s (%ld kB) vs one band %.3f s (%ld kB); "
      "maps %s\n",
      grid.c_str(), bands, banded.seconds, banded.max_rss_kb, one.seconds, one.max_rss_kb,
      same ? "the same bytes" : "DIFFER");
  return e;
}

}  // namespace

json bench_fit_process(const std::string& work, bool quick) {
  json out = json::array();
  struct Set {
    const char* name;
    int views, side;
    double target_s;
  };
  // The process's own baseline: `aniso fit --help` loads what a fit loads and does nothing (the
  // plain `aniso` hands `--version` over to aniso-full: two starts and the larger binary).
  const Run start = median_of_three({"fit", "--help"});
  for (const Set& s : {Set{"bm16", 16, 128, 0.040}, Set{"bm64", 64, 256, 0.3}}) {
    PresetOptions po;
    po.views = quick ? s.views / 4 : s.views;
    po.width = po.height = quick ? s.side / 2 : s.side;
    po.noise = 0.01;
    po.progress = nullptr;
    SimOptions so = make_preset("brushed-metal", po);
    so.compression = ExrCompression::kNone;  // what aniso synth writes by default
    const std::string dir = join_path(work, s.name);
    simulate_capture(so, dir);
    // The set on disk before the clock starts, as a user's set is: not the kernel writing back
    // the 15-60 MB just written while the fits are timed.
    ::sync();
    Run runs[2];
    double err[2] = {NAN, NAN};
    size_t pixels = 0;
    for (int k = 0; k < 2; ++k) {
      const std::string mat =
          join_path(work, std::string(s.name) + (k ? "_ceres" : "_fused") + ".json");
      runs[k] = median_of_three({"fit", dir, "--out", mat, "--solver", k ? "ceres" : "fused"});
      if (!runs[k].ok) continue;
      const Material m = read_material(mat);
      err[k] = errors_of(m, so.truth).worst();
      const auto rep = jsonu::json::parse(read_text_file(mat), nullptr, false);
      if (rep.is_object() && rep.contains("report"))
        pixels = rep["report"].value("pixels", size_t{0});
    }
    json e =
        entry("fit",
              std::string("whole process: aniso fit ") + s.name + " (" + std::to_string(po.views) +
                  " views of " + std::to_string(po.width) + "^2), fused LM vs --solver ceres",
              runs[0].seconds, runs[1].seconds, "s", err[0]);
    e["baseline_error"] = std::isfinite(err[1]) ? json(err[1]) : json(nullptr);
    e["peak_rss_kb"] = {{"fused", runs[0].max_rss_kb},
                        {"ceres", runs[1].max_rss_kb},
                        {"process_start", start.max_rss_kb}};
    e["process_start_s"] = start.seconds;
    e["exr_compression"] = "none";
    if (!quick)
      target(&e, "whole process <= " + std::to_string(s.target_s) + " s at the same error",
             runs[0].ok && runs[0].seconds <= s.target_s, "see BENCHMARKS.md: where the time goes");
    out.push_back(e);
    // Memory above the process's own start against the observations' own record (14 float64
    // per pixel and light, as BENCHMARKS.md counts it).
    const double own_kb = pixels * 14 * 8 / 1024.0;
    json m =
        entry("fit", std::string("peak memory above process start over the records, ") + s.name,
              own_kb > 0 ? (runs[0].max_rss_kb - start.max_rss_kb) / own_kb : NAN,
              own_kb > 0 ? (runs[1].max_rss_kb - start.max_rss_kb) / own_kb : NAN, "ratio", NAN);
    m["observations_kb"] = own_kb;
    if (!quick)
      target(&m, "<= 1x the observations' own record",
             runs[0].max_rss_kb - start.max_rss_kb <= own_kb,
             "double-precision per-pixel records (BENCHMARKS.md)");
    out.push_back(m);
    std::printf(
        "bench fit: whole process %s: fused %.3f s (%ld kB), ceres %.3f s (%ld kB), process start "
        "%.3f s (%ld kB); error %.2e vs %.2e; memory above start %.2fx the records\n",
        s.name, runs[0].seconds, runs[0].max_rss_kb, runs[1].seconds, runs[1].max_rss_kb,
        start.seconds, start.max_rss_kb, err[0], err[1],
        own_kb > 0 ? (runs[0].max_rss_kb - start.max_rss_kb) / own_kb : NAN);
  }
  out.push_back(maps_entry(work, quick, 16));
  if (!quick) out.push_back(maps_entry(work, quick, 64));
  out.push_back(lanes_entry(work, quick, 64));
  out.push_back(bands_entry(work, quick, 64));
  out.push_back(fiber_entry(work, quick, "fiber-flat", "fiber"));
  out.push_back(fiber_entry(work, quick, "brushed-metal", "fiber"));
  out.push_back(fiber_entry(work, quick, "brushed-metal", "auto"));
  return out;
}

}  // namespace aniso::benchutil
