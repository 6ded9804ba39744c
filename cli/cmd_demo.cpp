// aniso demo: the main job end to end on the built-in default.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "capture_sim/sim.h"
#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "datasets_synth/presets.h"
#include "fit/fit.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "render/bake/bake.h"
#include "render/preview/preview.h"

namespace aniso::cli {

namespace {
struct DemoArgs {
  std::string out = "demo_out", size = "128x128";
  int views = 16;
  uint64_t seed = 1;
  bool force = false;
};

int run(const DemoArgs& a) {
  int w, h;
  parse_size(a.size, &w, &h);
  const std::string cap = join_path(a.out, "capture"), bake = join_path(a.out, "bake");
  check_output_folder(cap, OutputKind::kCapture, a.force);
  check_output_folder(bake, OutputKind::kBake, a.force);
  check_output_file(join_path(a.out, "material.json"), OutputKind::kMaterial, a.force);
  check_output_file(join_path(a.out, "preview.png"), OutputKind::kPreview, a.force);
  std::filesystem::create_directories(a.out);
  PresetOptions dp;
  dp.progress = terminal_progress();
  dp.views = a.views;
  dp.width = w;
  dp.height = h;
  dp.seed = a.seed;
  std::printf("== 1/4 synth: brushed-metal, %d views, %dx%d, noise-free float EXR, seed %llu\n",
              a.views, w, h, static_cast<unsigned long long>(a.seed));
  const SimStats st = simulate_capture(make_preset("brushed-metal", dp), cap);
  std::printf(
      "   %zu primary rays, %zu shadow rays (a flat sample cannot shadow itself), %.2f s -> %s\n",
      st.primary_rays, st.shadow_rays, st.seconds, cap.c_str());
  std::printf("== 2/4 fit: line model\n");
  const std::string mat = join_path(a.out, "material.json");
  FitOptions fo;
  fo.progress = terminal_progress();
  run_fit(cap, fo, mat, "");
  std::printf("== 3/4 bake\n");
  const Material m = read_material(mat);
  const BakeTables t = bake_line(m, 256);
  write_bake(bake, m, t, shareable_command_line(bake));
  std::printf("   256x256 tables in %.3f s; lookup vs direct: max abs %.3g, RMS %.3g -> %s\n",
              t.seconds, t.max_abs_error, t.rms_error, bake.c_str());
  std::printf(
      "== 4/4 preview: satin sphere with the fitted material (fibers along dP/du, rotated by "
      "psi)\n");
  PreviewOptions p;
  p.progress = terminal_progress();
  p.reference = true;
  const PreviewResult r = render_preview(m, p);
  const std::string png = join_path(a.out, "preview.png");
  write_png(png, encode_srgb(r.rgb, 1.0), 8);
  std::printf(
      "   %d passes, %.2f ms/frame on %s; baked vs direct: max abs %.3g (bound %.3g) -> %s\n",
      r.passes, 1e3 * r.seconds_per_frame, r.renderer.c_str(), r.max_abs_diff, r.error_bound,
      png.c_str());
  return 0;
}
}  // namespace

Command add_demo(CLI::App& app) {
  auto a = std::make_shared<DemoArgs>();
  auto* demo = app.add_subcommand(
      "demo",
      "The main job end to end on the built-in default: synth brushed-metal -> fit -> bake -> "
      "preview PNG; prints recovered parameters next to the truth");
  demo->add_option("--out", a->out, "output folder")->capture_default_str();
  demo->add_option("--views", a->views, "views in the capture")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  demo->add_option("--size", a->size, "image size WxH")->capture_default_str();
  demo->add_option("--seed", a->seed, "seed for every random choice")->capture_default_str();
  add_force_flag(demo, &a->force);
  return {demo, [a] { return run(*a); }};
}

}  // namespace aniso::cli
