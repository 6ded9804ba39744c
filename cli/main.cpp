// aniso: the command-line front end. Thin: parses options, calls the library, prints results.
// Library errors (aniso::Error) are printed with their file/key and exit with status 1.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "bench/suites.h"
#include "capture_sim/microgeometry.h"
#include "capture_sim/sim.h"
#include "core/error.h"
#include "datasets_synth/presets.h"
#include "fit/fit.h"
#include "io/capture.h"
#include "io/files.h"
#include "io/image_io.h"
#include "io/material_io.h"
#include "io/table.h"
#include "models/evaluate.h"
#include "models/params.h"
#include "render/bake.h"
#include "render/preview.h"
#include "render/verify.h"

namespace fs = std::filesystem;
using namespace aniso;

namespace {

std::string g_command_line;

void parse_size(const std::string& s, int* w, int* h) {
  int a = 0, b = 0;
  char x = 0, extra = 0;
  if (std::sscanf(s.c_str(), "%d%c%d%c", &a, &x, &b, &extra) == 3 && (x == 'x' || x == 'X')) {
    *w = a;
    *h = b;
  } else if (std::sscanf(s.c_str(), "%d%c", &a, &extra) == 1) {
    *w = *h = a;
  } else {
    throw Error("--size: expected WxH or N, got '" + s + "'");
  }
  if (*w < 1 || *h < 1) throw Error("--size: must be positive, got '" + s + "'");
}

Vec3 parse_vec(const std::string& s, const std::string& opt) {
  Vec3 v;
  char extra;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf%c", &v.x, &v.y, &v.z, &extra) != 3 || !finite(v) ||
      length(v) == 0)
    throw Error(opt + ": expected a non-zero direction x,y,z, got '" + s + "'");
  return v;
}

// A capture folder / capture.json, or a sample table (.csv).
bool is_table(const std::string& p) { return lower_ext(p) == ".csv"; }

void print_report(const FitResult& r) {
  const FitReport& p = r.report;
  std::printf(
      "fit: %zu observations (%zu pixels x 3 channels) from %zu views; skipped: %zu masked, %zu "
      "saturated, "
      "%zu non-finite, %zu unlit, %zu implausible\n",
      p.observations, p.pixels, p.views, p.masked_out, p.saturated, p.nonfinite, p.unlit,
      p.implausible);
  std::printf("fit: start %s\n", p.start.c_str());
  std::printf(
      "fit: %d iterations, %s, loss %s, residual RMS %.3g, time %.3f s (load %.3f, start %.3f, "
      "solve %.3f, "
      "covariance %.3f)\n",
      p.iterations, p.termination.c_str(), p.loss.c_str(), p.rms, p.seconds, p.seconds_load,
      p.seconds_start, p.seconds_solve, p.seconds_covariance);
  for (const auto& [k, why] : r.undetermined)
    std::printf("fit: UNDETERMINED %s: %s\n", k.c_str(), why.c_str());
  if (!p.model_selection.empty()) std::printf("fit: --model auto: %s\n", p.model_selection.c_str());
}

void print_material(const Material& m) {
  std::printf(
      "  model %s: kd = [%.5f, %.5f, %.5f]  ks = [%.5f, %.5f, %.5f]  n = %.4g  fiber_angle_deg = "
      "%.3f",
      m.model.c_str(), m.kd[0], m.kd[1], m.kd[2], m.ks[0], m.ks[1], m.ks[2], m.n,
      m.fiber_angle_deg);
  if (m.model == "fiber") {
    if (m.has_topology_map)
      std::printf("  topology map %s, amplitude %.4f over %s", m.topology_map.c_str(),
                  m.topology_amplitude, m.topology_mathematical.c_str());
    else if (m.has_s_map)
      std::printf("  topology: a per-texel map of s");
    else if (m.topology_mathematical == "none")
      std::printf("  topology s = %.4f", m.topology_s);
    else
      std::printf("  topology: %s (per-pixel buffer)", m.topology_mathematical.c_str());
  }
  std::printf("\n");
}

int run_fit(const std::string& input, const FitOptions& fo, const std::string& out,
            const std::string& truth_path) {
  FitResult r;
  std::string truth = truth_path;
  if (is_table(input)) {
    r = fit_table(read_table(input), fo);
  } else {
    const CaptureSet set = read_capture(input);
    r = fit_capture(set, fo);
    if (truth.empty() && !set.truth.empty()) truth = join_path(set.dir, set.truth);
  }
  write_fit(out, r);
  print_report(r);
  std::printf("fit: wrote %s\n", out.c_str());
  print_material(r.material);
  if (!truth.empty()) {
    const Material t = read_material(truth);
    std::printf("against the truth (%s):\n%s", truth.c_str(),
                compare_to_truth(r, t, nullptr).c_str());
  }
  return 0;
}

PreviewOptions preview_defaults_for(const std::string& shape) {
  PreviewOptions p;
  p.shape = shape;
  return p;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  for (int i = 0; i < argc; ++i) g_command_line += (i ? " " : "") + std::string(argv[i]);
  CLI::App app{
      "aniso: measure and fit anisotropic materials (line-lighting model of Banks / Heidrich & "
      "Seidel).\n"
      "Pipeline: synth (simulated gonioreflectometer on Embree) -> fit (Ceres) -> bake (lookup "
      "tables) -> "
      "preview (OpenGL, headless).",
      "aniso"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "aniso 0.1");

  // demo --------------------------------------------------------------------------------------
  auto* demo = app.add_subcommand(
      "demo",
      "The main job end to end on the built-in default: synth brushed-metal -> "
      "fit -> bake -> preview PNG; prints recovered parameters next to the truth");
  std::string demo_out = "demo_out";
  int demo_views = 16;
  std::string demo_size = "128x128";
  uint64_t demo_seed = 1;
  demo->add_option("--out", demo_out, "output folder")->capture_default_str();
  demo->add_option("--views", demo_views, "views in the capture")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  demo->add_option("--size", demo_size, "image size WxH")->capture_default_str();
  demo->add_option("--seed", demo_seed, "seed for every random choice")->capture_default_str();

  // synth -------------------------------------------------------------------------------------
  auto* synth = app.add_subcommand("synth", "Make a ground-truth capture set from a named preset");
  std::string preset, synth_out, synth_size = "128x128";
  PresetOptions po;
  bool synth_list = false;
  std::string truth_override;
  synth->add_option("PRESET", preset, "preset name (--list shows them)");
  synth->add_option("OUT_DIR", synth_out, "capture folder to write (replaced atomically)");
  synth->add_flag("--list", synth_list, "list the presets and exit");
  synth
      ->add_option("--noise", po.noise,
                   "Gaussian read noise sigma, as a fraction of the white level (0.01 = 1%)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  synth
      ->add_option("--shot", po.shot_photons,
                   "Poisson shot noise: photons at the white level (0 = off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  synth->add_option("--seed", po.seed, "seed for every random draw (recorded in capture.json)")
      ->capture_default_str();
  synth->add_option("--views", po.views, "number of views")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  synth->add_option("--size", synth_size, "image size WxH")->capture_default_str();
  synth->add_option("--bits", po.bits, "0 = float EXR, 8 or 16 = PNG")
      ->capture_default_str()
      ->check(CLI::IsMember({0, 8, 16}));
  synth->add_option("--encoding", po.encoding, "PNG encoding")
      ->capture_default_str()
      ->check(CLI::IsMember({"linear", "srgb"}));
  synth
      ->add_option("--saturation", po.saturation,
                   "sensor clips at this fraction of the white level (0 = never); clipped values "
                   "are flagged in "
                   "capture.json so the fit leaves them out")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  synth->add_option("--rig", po.rig,
                    "fixed-camera, orbit, or a rig JSON file (default: the preset's)");
  synth->add_option("--truth", truth_override,
                    "use this material file as the ground truth instead");
  std::string synth_compression = "none";
  synth
      ->add_option(
          "--exr-compression", synth_compression,
          "EXR compression: none (fastest), zip (zlib level 1, about half the size) or piz")
      ->capture_default_str()
      ->check(CLI::IsMember({"zip", "piz", "none"}));
  synth->add_option("--topology-s", po.topology_s, "fiber-flat: the sample's topology value s")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  synth->add_option("--topology-map", po.topology_map_file,
                    "silk-torus: topology map image (default: seeded noise)");
  synth->add_option("--amplitude", po.topology_amplitude, "silk-torus: topology map amplitude A")
      ->capture_default_str()
      ->check(CLI::Range(-2.0, 2.0));

  // fit ---------------------------------------------------------------------------------------
  auto* fit =
      app.add_subcommand("fit", "Fit model parameters to a capture set or a sample table (CSV)");
  std::string fit_in, fit_out, fit_truth;
  FitOptions fo;
  fit->add_option("CAPTURE", fit_in, "capture folder, its capture.json, or a sample table .csv")
      ->required();
  fit->add_option("--model", fo.model, "model to fit")
      ->capture_default_str()
      ->check(CLI::IsMember({"line", "fiber", "auto"}));
  fit->add_option("--out", fit_out, "material file to write")->required();
  fit->add_option(
      "--truth", fit_truth,
      "ground-truth material: print every parameter's error (default: the set's truth)");
  fit->add_option("--subsample", fo.subsample, "use every k-th pixel in x and y")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  fit->add_option("--loss", fo.loss, "robust loss, scaled to 3 robust sigmas of the residuals")
      ->capture_default_str()
      ->check(CLI::IsMember({"huber", "cauchy", "none"}));
  fit->add_flag("--fit-isotropic", fo.fit_isotropic,
                "also fit the isotropic (Lambert + Blinn-Phong) term");
  fit->add_flag("--fit-second-fiber", fo.fit_second,
                "also fit a second fiber direction and its weight (woven cloth)");
  fit->add_option("--topology-map", fo.topology_texels,
                  "fiber model: fit a per-texel map of s, N x N texels over uv (written beside "
                  "--out as an EXR)")
      ->check(CLI::Range(2, 256));
  fit->add_option("--threads", fo.threads, "solver threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  fit->add_option("--max-iterations", fo.max_iterations, "solver iterations")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));

  // eval --------------------------------------------------------------------------------------
  auto* eval = app.add_subcommand("eval", "Fill in a sample table (CSV) by evaluating a material");
  std::string eval_mat, eval_table, eval_out;
  eval->add_option("MATERIAL", eval_mat, "material file")->required();
  eval->add_option("--table", eval_table,
                   "sample table: theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg[,...]")
      ->required();
  eval->add_option("--out", eval_out, "table to write with r,g,b")->required();

  // bake --------------------------------------------------------------------------------------
  auto* bake =
      app.add_subcommand("bake", "Bake the lookup textures (EXR, 8/16-bit PNG, JSON sidecar)");
  std::string bake_mat, bake_out;
  int bake_size = 256;
  bake->add_option("MATERIAL", bake_mat, "material file")->required();
  bake->add_option("--out", bake_out, "output folder (replaced atomically)")->required();
  bake->add_option("--size", bake_size, "table size N (N x N)")
      ->capture_default_str()
      ->check(CLI::Range(2, 8192));
  std::string bake_index = "angle";
  bake->add_option("--index", bake_index,
                   "texel spacing: angle (uniform in acos, default) or cosine (the paper's)")
      ->capture_default_str()
      ->check(CLI::IsMember({"angle", "cosine"}));

  // preview -----------------------------------------------------------------------------------
  auto* prev = app.add_subcommand(
      "preview", "Render an object headless through OpenGL with the baked texture");
  std::string prev_mat, prev_out, prev_shape = "sphere", prev_field, prev_size = "512x512",
                                  prev_view, prev_exr;
  std::vector<std::string> prev_lights;
  double prev_exposure = 1.0;
  int prev_table = 256;
  prev->add_option("MATERIAL", prev_mat, "material file")->required();
  prev->add_option("--out", prev_out, "PNG to write (sRGB, 8-bit)")->required();
  prev->add_option("--shape", prev_shape, "sphere, disc, cylinder, torus, flat, or an .obj file")
      ->capture_default_str();
  prev->add_option("--fiber-field", prev_field, "replace dP/du: radial, circular or meridian")
      ->check(CLI::IsMember({"", "radial", "circular", "meridian"}));
  prev->add_option("--size", prev_size, "image size WxH")->capture_default_str();
  prev->add_option("--light", prev_lights,
                   "direction toward a light x,y,z (repeat for more lights; one pass each)");
  prev->add_option("--view", prev_view, "direction toward the viewer x,y,z");
  prev->add_option("--exposure", prev_exposure, "scale before sRGB encoding")
      ->capture_default_str();
  prev->add_option("--table-size", prev_table, "lookup table size")
      ->capture_default_str()
      ->check(CLI::Range(2, 8192));
  prev->add_option("--exr", prev_exr, "also write the linear float image here");
  std::string prev_map;
  bool prev_paper = false;
  prev->add_flag("--per-vertex", prev_paper,
                 "the paper's construction exactly: texture matrix per vertex, cosine table");
  double prev_R = 1.0, prev_r = 0.6;
  prev->add_option("--topology-map", prev_map,
                   "fiber model: topology map image (default: the material's, relative to it)");
  prev->add_option("--torus-R", prev_R, "torus major radius (shape torus)")->capture_default_str();
  prev->add_option("--torus-r", prev_r, "torus minor radius (shape torus)")->capture_default_str();
  std::string prev_index = "angle";
  prev->add_option("--index", prev_index, "lookup table spacing: angle or cosine (see bake --help)")
      ->capture_default_str()
      ->check(CLI::IsMember({"angle", "cosine"}));

  // verify ------------------------------------------------------------------------------------
  auto* ver = app.add_subcommand(
      "verify", "Render a capture's views with a material and report the error per view");
  std::string ver_cap, ver_mat;
  ver->add_option("CAPTURE", ver_cap, "capture folder or capture.json")->required();
  ver->add_option("MATERIAL", ver_mat, "material file")->required();
  std::string ver_resid;
  ver->add_option("--residuals", ver_resid,
                  "folder for per-view residual images (model - image, float EXR)");

  // microgeometry -----------------------------------------------------------------------------
  auto* micro = app.add_subcommand("microgeometry",
                                   "Virtual gonioreflectometer: measure a patch of Embree "
                                   "cylinders against the fiber model over a "
                                   "sweep of directions and topology values");
  std::string micro_out;
  int micro_rays = 20000;
  double micro_n = 20;
  uint64_t micro_seed = 1;
  micro->add_option("--out", micro_out, "CSV with model and measured D, S per configuration")
      ->required();
  micro->add_option("--rays", micro_rays, "primary rays per configuration")
      ->capture_default_str()
      ->check(CLI::Range(100, 100000000));
  micro->add_option("--n", micro_n, "specular exponent")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e4));
  micro->add_option("--seed", micro_seed, "seed of the ray jitter")->capture_default_str();

  // bench -------------------------------------------------------------------------------------
  auto* bench = app.add_subcommand(
      "bench",
      "End-to-end comparisons in one run: fit (vs SciPy), fiber (vs brute force), "
      "bake, capture (vs bare Embree), preview (vs a plain pass), skips, all");
  std::string bench_suite, bench_out, bench_work = "bench_work";
  bool bench_quick = false;
  bench->add_option("SUITE", bench_suite, "fit, fiber, bake, capture, preview, skips or all")
      ->required();
  bench
      ->add_option("--out", bench_out,
                   "JSON file of entries {name, ours, baseline, ratio, error, unit, ...}")
      ->required();
  bench->add_option("--work", bench_work, "folder for the synthetic sets it makes")
      ->capture_default_str();
  bench->add_flag("--quick", bench_quick, "small sweeps (for tests)");

  // params ------------------------------------------------------------------------------------
  auto* params = app.add_subcommand(
      "params", "Print the model parameters: name, bounds, default, unit, periodic");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    if (*params) {
      std::printf("%-24s %-8s %4s %10s %10s %8s %5s %8s %s\n", "key", "symbol", "dims", "min",
                  "max", "default", "unit", "periodic", "meaning");
      auto print = [](const ParamSpec& p, const char* model) {
        std::printf("%-24s %-8s %4d %10g %10g %8g %5s %8s %s\n", std::string(p.key).c_str(),
                    std::string(p.symbol).c_str(), p.dims, p.lo, p.hi, p.def,
                    p.unit.empty() ? "-" : std::string(p.unit).c_str(), p.periodic ? "yes" : "no",
                    (std::string(p.doc) + model).c_str());
      };
      for (const auto& p : kLineParams) print(p, "");
      for (const auto& p : kFiberParams) print(p, " [fiber model]");
      return 0;
    }
    if (*synth) {
      if (synth_list) {
        for (const auto& [name, desc] : preset_list())
          std::printf("%-14s %s\n", name.c_str(), desc.c_str());
        return 0;
      }
      if (preset.empty() || synth_out.empty())
        throw Error("synth: needs PRESET and OUT_DIR (see --list)");
      parse_size(synth_size, &po.width, &po.height);
      set_exr_compression(synth_compression);
      SimOptions so = make_preset(preset, po);
      if (!truth_override.empty()) so.truth = read_material(truth_override);
      const SimStats st = simulate_capture(so, synth_out);
      std::printf(
          "synth: %s -> %s: %zu views %dx%d, seed %llu; %zu primary rays, %zu shadow rays, %zu "
          "shaded pixels, "
          "%zu light evaluations, %zu (view, light) pairs culled; %.2f s (trace %.2f, shade %.2f, "
          "write %.2f)\n",
          preset.c_str(), synth_out.c_str(), st.views, po.width, po.height,
          static_cast<unsigned long long>(po.seed), st.primary_rays, st.shadow_rays,
          st.shaded_pixels, st.light_evals, st.lights_culled, st.seconds, st.seconds_trace,
          st.seconds_shade, st.seconds_write);
      return 0;
    }
    if (*fit) {
      return run_fit(fit_in, fo, fit_out, fit_truth);
    }
    if (*eval) {
      const Material m = read_material(eval_mat);
      SampleTable t = read_table(eval_table);
      const Evaluator ev(m);
      for (auto& row : t.rows) {
        double f[3];
        if (t.has_s)
          ev(dir_from_angles(row.theta_i, row.phi_i), dir_from_angles(row.theta_o, row.phi_o), f,
             row.s);
        else
          ev(dir_from_angles(row.theta_i, row.phi_i), dir_from_angles(row.theta_o, row.phi_o), f);
        for (int c = 0; c < 3; ++c) row.value[c] = f[c];
      }
      t.values = SampleTable::Values::kRGB;
      write_table(eval_out, t);
      std::printf("eval: %zu rows -> %s\n", t.rows.size(), eval_out.c_str());
      return 0;
    }
    if (*bake) {
      const Material m = read_material(bake_mat);
      const BakeTables t = bake_line(m, bake_size, parse_index(bake_index));
      FiberBakeTables fb;
      if (m.model == "fiber") {
        fb = bake_fiber(m, t);
        std::printf(
            "bake: fiber factor tables %dx%dx%d (G) and x%d (F) in %.2f s; baked vs full fiber "
            "model over %zu "
            "samples: max abs %.3g, p99 %.3g, RMS %.3g (peak %.3g)\n",
            fb.nphi, fb.nphi, fb.ns, fb.nk, fb.seconds, fb.samples, fb.max_abs_error, fb.p99_error,
            fb.rms_error, fb.peak_value);
      }
      write_bake(bake_out, m, t, g_command_line, m.model == "fiber" ? &fb : nullptr);
      std::printf(
          "bake: %dx%d tables (%s index) in %.3f s -> %s; bilinear lookup vs direct evaluation "
          "over %zu samples: max abs "
          "%.3g, RMS %.3g (peak value %.3g)\n",
          bake_size, bake_size, index_name(t.index), t.seconds, bake_out.c_str(), t.samples,
          t.max_abs_error, t.rms_error, t.peak_value);
      return 0;
    }
    if (*prev) {
      const Material m = read_material(prev_mat);
      PreviewOptions p = preview_defaults_for(prev_shape);
      p.fiber_field = prev_field;
      parse_size(prev_size, &p.width, &p.height);
      p.table_size = prev_table;
      p.table_index = parse_index(prev_index) == BakeIndex::kAngle ? 1 : 0;
      p.per_vertex = prev_paper;
      if (!prev_view.empty()) p.view_dir = parse_vec(prev_view, "--view");
      if (!prev_lights.empty()) {
        p.light_dirs.clear();
        for (const auto& l : prev_lights) p.light_dirs.push_back(parse_vec(l, "--light"));
      }
      p.reference = true;
      if (m.model == "fiber" && m.has_topology_map) {
        // The map named by the material, relative to the material file, unless given.
        const std::string map_path =
            prev_map.empty() ? join_path(parent_dir(prev_mat), m.topology_map) : prev_map;
        p.topology_map = load_topology_map(map_path).h;
      }
      p.shape_options.torus_R = prev_R;
      p.shape_options.torus_r = prev_r;
      const PreviewResult r = render_preview(m, p);
      Image out = r.rgb;
      for (float& v : out.px) {
        const double x = std::clamp(v * prev_exposure, 0.0, 1.0);
        v = float(x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055);
      }
      write_png(prev_out, out, 8);
      if (!prev_exr.empty()) write_exr(prev_exr, r.rgb);
      std::printf(
          "preview: %s, %zu triangles, %d passes, %.2f ms/frame on %s -> %s; baked vs direct "
          "evaluation: max "
          "abs difference %.3g (bound %.3g)",
          p.shape.c_str(), r.triangles, r.passes, 1e3 * r.seconds_per_frame, r.renderer.c_str(),
          prev_out.c_str(), r.max_abs_diff, r.error_bound);
      if (m.model == "fiber")
        std::printf("; GPU vs the same tables on the CPU: %.3g", r.max_abs_diff_baked);
      std::printf("\n");
      return 0;
    }
    if (*bench) {
      run_bench(bench_suite, bench_out, bench_work, bench_quick);
      return 0;
    }
    if (*micro) {
      const MicroSweepSummary m = micro_sweep(micro_out, micro_n, micro_rays, micro_seed, true);
      std::printf(
          "microgeometry: %zu configurations (5 topology values x 144 direction pairs), %zu rays, "
          "%.1f s -> %s\n"
          "  model vs measured: max |dD| = %.2e (%.1f standard errors), max |dS| = %.2e (%.1f "
          "standard errors)\n",
          m.configs, m.rays, m.seconds, micro_out.c_str(), m.max_dD, m.max_zD, m.max_dS, m.max_zS);
      return 0;
    }
    if (*ver) {
      const CaptureSet set = read_capture(ver_cap);
      const Material m = read_material(ver_mat);
      const VerifyResult r = verify_capture(set, m, ver_resid);
      std::printf("%-6s %8s %12s %12s %10s\n", "view", "pixels", "rms", "max_abs", "rel_rms");
      for (size_t i = 0; i < r.views.size(); ++i)
        std::printf("%-6zu %8zu %12.4g %12.4g %9.4f%%\n", i, r.views[i].pixels, r.views[i].rms,
                    r.views[i].max_abs, 100 * r.views[i].rel_rms());
      std::printf("%-6s %8zu %12.4g %12.4g %9.4f%%\n", "all", r.overall.pixels, r.overall.rms,
                  r.overall.max_abs, 100 * r.overall.rel_rms());
      return 0;
    }
    if (*demo) {
      int w, h;
      parse_size(demo_size, &w, &h);
      PresetOptions dp;
      dp.views = demo_views;
      dp.width = w;
      dp.height = h;
      dp.seed = demo_seed;
      fs::create_directories(demo_out);
      const std::string cap = join_path(demo_out, "capture");
      std::printf("== 1/4 synth: brushed-metal, %d views, %dx%d, noise-free float EXR, seed %llu\n",
                  demo_views, w, h, static_cast<unsigned long long>(demo_seed));
      const SimOptions so = make_preset("brushed-metal", dp);
      const SimStats st = simulate_capture(so, cap);
      std::printf(
          "   %zu primary rays, %zu shadow rays (a flat sample cannot shadow itself), %.2f s -> "
          "%s\n",
          st.primary_rays, st.shadow_rays, st.seconds, cap.c_str());
      std::printf("== 2/4 fit: line model\n");
      const std::string mat = join_path(demo_out, "material.json");
      run_fit(cap, FitOptions{}, mat, "");
      std::printf("== 3/4 bake\n");
      const Material m = read_material(mat);
      const BakeTables t = bake_line(m, 256);
      write_bake(join_path(demo_out, "bake"), m, t, g_command_line);
      std::printf("   256x256 tables in %.3f s; lookup vs direct: max abs %.3g, RMS %.3g -> %s\n",
                  t.seconds, t.max_abs_error, t.rms_error, join_path(demo_out, "bake").c_str());
      std::printf(
          "== 4/4 preview: satin sphere with the fitted material (fibers along dP/du, rotated by "
          "psi)\n");
      PreviewOptions p;
      p.reference = true;
      const PreviewResult r = render_preview(m, p);
      Image out = r.rgb;
      for (float& v : out.px) {
        const double x = std::clamp(double(v), 0.0, 1.0);
        v = float(x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055);
      }
      const std::string png = join_path(demo_out, "preview.png");
      write_png(png, out, 8);
      std::printf(
          "   %d passes, %.2f ms/frame on %s; baked vs direct: max abs %.3g (bound %.3g) -> %s\n",
          r.passes, 1e3 * r.seconds_per_frame, r.renderer.c_str(), r.max_abs_diff, r.error_bound,
          png.c_str());
      return 0;
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "aniso: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "aniso: internal error: %s\n", e.what());
    return 2;
  }
  return 0;
}
