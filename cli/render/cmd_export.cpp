// aniso export: tables, shaders and glTF for engines and browsers (render/export/export.h).
#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "core/angles.h"
#include "core/error.h"
#include "core/shell.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "render/export/export.h"

namespace aniso::cli {

namespace {

// --engines: the camera, lights and frame of the comparison, `aniso preview`'s flags and the
// engines page's query alike (web/engines.js).
constexpr const char* kEngineView = "0.3,-0.8,0.5";
constexpr const char* kEngineLight = "0.6,-0.1,0.8";
constexpr int kEngineW = 200, kEngineH = 160;

// The mean absolute difference of two frames of one size, as a fraction of full scale, and the
// second's mean value.
double mean_abs_difference(const Image& a, const Image& b, double* b_mean) {
  if (a.width != b.width || a.height != b.height) return NAN;
  double sum = 0, lit = 0;
  size_t n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int c = 0; c < 3; ++c, ++n) {
        sum += std::abs(a.at(x, y, c) - b.at(x, y, c));
        lit += b.at(x, y, c);
      }
  *b_mean = lit / static_cast<double>(n);
  return sum / static_cast<double>(n);
}

// The repository's web/ with its npm packages (the engines' loaders): ANISO_WEB_DIR, else the
// source tree's. Throws saying what is missing.
std::string engines_web_dir() {
  const char* env = std::getenv("ANISO_WEB_DIR");
  const std::string web = env && *env ? env : std::string(ANISO_SOURCE_DIR) + "/web";
  for (const char* need : {"/engines.sh", "/node_modules/babylonjs", "/node_modules/three",
                           "/node_modules/@khronosgroup/gltf-viewer"})
    if (!std::filesystem::exists(web + need))
      throw Error("export --engines: " + web + need +
                  " not found: the engines render in headless Chromium from the repository's "
                  "web/ with its npm packages (scripts/install_deps.sh installs them; "
                  "ANISO_WEB_DIR names another web/)");
  return web;
}

// `aniso preview` of the material and each engine's frame of the export in `dir`: their mean
// absolute differences (export.json's engines_measured).
nlohmann::json measure_engines(const std::string& material, const std::string& dir,
                               const std::string& web) {
  std::string tmp = (std::filesystem::temp_directory_path() / "aniso-engines-XXXXXX").string();
  if (!::mkdtemp(tmp.data())) throw Error("export --engines: cannot make a temporary folder");
  struct Remove {
    std::string p;
    ~Remove() {
      std::error_code ec;
      std::filesystem::remove_all(p, ec);
    }
  } remove{tmp};
  const std::string size = std::to_string(kEngineW) + "x" + std::to_string(kEngineH);
  std::string out;
  const std::string preview = tmp + "/preview.png";
  std::string self = program_beside_self("aniso-full");
  if (self.empty()) self = program_beside_self("aniso");
  if (run_shell(shell_quoted(self) + " preview " + shell_quoted(material) +
                    " --shape sphere --view " + kEngineView + " --light " + kEngineLight +
                    " --size " + size + " --out " + shell_quoted(preview),
                &out) != 0)
    throw Error("export --engines: aniso preview failed: " + out);
  const Image exact = read_image(preview).image;
  nlohmann::json j = {{"against", "aniso preview (the exact model) of the material"},
                      {"camera", std::string("orthographic, view ") + kEngineView},
                      {"light", std::string(kEngineLight) + " and the preview's fill"},
                      {"size", {kEngineW, kEngineH}},
                      {"shape", "sphere"},
                      {"measure", "mean |difference| of the sRGB frames, fraction of full scale"}};
  const std::string query =
      std::string("view=") + kEngineView + "&light=" + kEngineLight + "&size=" + size;
  std::map<std::string, Image> frames;
  for (const char* engine : {"three", "babylon", "khronos"}) {
    const std::string png = tmp + "/" + engine + ".png";
    std::string said;
    std::printf("export --engines: %s in headless Chromium...\n", engine);
    std::fflush(stdout);
    const int st = run_shell(shell_quoted(web + "/engines.sh") + " " + shell_quoted(dir) + " " +
                                 engine + " " + shell_quoted(query) + " " + shell_quoted(png) +
                                 " " + std::to_string(kEngineW) + " " + std::to_string(kEngineH),
                             &said);
    if (st != 0 || !std::filesystem::exists(png)) {
      j["engines"][engine] = {{"rendered", false}, {"why", said.substr(0, 400)}};
      continue;
    }
    frames[engine] = read_image(png).image;
    double mean = 0;
    const double d = mean_abs_difference(frames[engine], exact, &mean);
    j["engines"][engine] = {{"rendered", true}, {"mean_abs_difference", d}, {"preview_mean", mean}};
  }
  if (frames.count("three"))
    for (const char* other : {"babylon", "khronos"})
      if (frames.count(other)) {
        double mean = 0;
        j["three_against"][other] = mean_abs_difference(frames["three"], frames[other], &mean);
      }
  return j;
}

}  // namespace

Command add_export(CLI::App& app) {
  struct Args {
    std::string mat, out, env;
    int size = 256;
    bool engines = false, force = false;
  };
  auto a = std::make_shared<Args>();
  auto* ex = app.add_subcommand(
      "export",
      "Export a material for engines: KTX2 + EXR tables, GLSL/HLSL lookup shaders, packages for "
      "Godot 4, Unity and Unreal (engines/, line materials), a glTF sample with "
      "KHR_materials_anisotropy, a three.js viewer, export.json with the conventions and "
      "measured errors; a material's maps go along as KTX2 with shaders that draw them per "
      "fragment");
  ex->add_option("MATERIAL", a->mat, "material file (aniso-material, e.g. what `fit` wrote)")
      ->required();
  ex->add_option("--out", a->out,
                 "export folder: new, empty, or an earlier export (replaced "
                 "atomically)")
      ->required();
  add_force_flag(ex, &a->force);
  ex->add_option(
      "--env", a->env,
      "the environment prefiltered for the material, which the browser viewer lights "
      "with: the built-in 'studio' (the default, left out with a note for a material "
      "it cannot carry: a second fiber beside a map of the fiber direction, the fiber model on "
      "a torus's topology), "
      "an equirectangular HDR FILE.exr (z up), or 'none'");
  ex->add_flag(
      "--engines", a->engines,
      "also render the exported glTF with three.js's GLTFLoader, Babylon.js and the "
      "Khronos glTF Sample Renderer in headless Chromium under `aniso preview`'s camera and "
      "lights, and record each one's difference from the exact model in export.json "
      "(engines_measured; needs the repository's web/ with its npm packages)");
  ex->add_option("--size", a->size, "line tables N x N")
      ->capture_default_str()
      ->check(CLI::Range(2, 8192));
  return {
      ex, [a] {
        const Material m = read_material(a->mat);
        check_outputs_apart({a->out}, material_input_files(m, a->mat));
        check_output_folder(a->out, OutputKind::kExport, a->force);
        ExportOptions o;
        o.progress = terminal_progress();
        o.size = a->size;
        o.command = shareable_command_line(a->out);
        Environment env;
        if (a->env != "none") {
          env = named_environment(a->env.empty() ? "studio" : a->env);
          o.environment = &env;
          o.environment_where_it_applies = a->env.empty();
        }
        std::string web;
        nlohmann::json measured;
        if (a->engines) {
          web = engines_web_dir();
          o.measure_engines = [&](const std::string& dir) {
            measured = measure_engines(a->mat, dir, web);
            return measured;
          };
        }
        const ExportSummary s = export_material(m, a->out, o);
        std::printf("export: %s model, %zu files in %.3f s -> %s\n", model_name(m.model),
                    s.files.size(), s.seconds, a->out.c_str());
        std::printf(
            "  tables %dx%d (KTX2 + EXR): bilinear lookup vs direct, max abs %.3g, "
            "RMS %.3g (peak %.3g)\n",
            s.line.size, s.line.size, s.line.max_abs_error, s.line.rms_error, s.line.peak_value);
        if (s.fiber)
          std::printf(
              "  fiber factor tables (2D arrays): vs the full model, max abs %.3g, "
              "p99 %.3g\n",
              s.fiber_tables.max_abs_error, s.fiber_tables.p99_error);
        std::printf(
            "  glTF KHR_materials_anisotropy: roughness %.3f, strength %.3f, "
            "rotation %.1f deg; GGX lobe vs the model's lobe: relative RMS %.3f\n",
            s.pbr.roughness, s.pbr.strength, rad_to_deg(s.pbr.rotation_rad), s.pbr.lobe_rel_rms);
        std::printf("  %s\n", s.pbr.mapping.c_str());
        if (o.environment && s.environment_left_out.empty())
          std::printf(
              "  environment %s prefiltered in %.2f s: %d tables in tables/, export.json "
              "tables.environment (the browser viewer's orbit view lights with it; --env none "
              "leaves it out)\n",
              env.name.c_str(), s.environment_seconds,
              static_cast<int>(std::count_if(s.files.begin(), s.files.end(), [](const auto& f) {
                return f.rfind("tables/", 0) == 0 && f.find("environment") != std::string::npos;
              })));
        else if (o.environment)
          std::printf("  no environment: %s (the browser viewer lights with its light and fill)\n",
                      s.environment_left_out.c_str());
        if (s.gltf_texels.w > 0)
          std::printf(
              "  glTF per texel (%dx%d, the lobe fitted at %d values of n): baseColorTexture, "
              "metallicRoughnessTexture, anisotropyTexture with its strength; whole-model "
              "relative RMS at worst %.3f\n",
              s.gltf_texels.w, s.gltf_texels.h, s.gltf_texels.nodes, s.gltf_texels.worst_rel_rms);
        if (s.maps.any()) {
          char stack[256] = "";
          if (s.maps.n)
            std::snprintf(stack, sizeof stack,
                          "; S from %d tables over the map's range of n, max abs %.3g",
                          s.maps.levels, s.stack_max_abs_error);
          if (s.fiber_stack.levels > 0)
            std::snprintf(stack + std::strlen(stack), sizeof stack - std::strlen(stack),
                          "; F from %d levels, vs the full model max abs %.3g, RMS %.2g",
                          s.fiber_stack.levels, s.fiber_stack.max_abs_error,
                          s.fiber_stack.rms_error);
          std::printf(
              "  maps per fragment (shaders/aniso_maps.*, the browser viewer):%s%s%s%s%s%s%s%s\n",
              s.maps.kd ? " k_d" : "", s.maps.ks ? " k_s" : "", s.maps.fiber ? " fiber" : "",
              s.maps.n ? " n" : "", s.maps.s_map ? " s" : "",
              s.maps.topology_map ? " topology-map" : "", s.maps.amplitude ? " amplitude" : "",
              stack);
        }
        if (!measured.is_null()) {
          std::printf(
              "  engines against aniso preview (mean |diff| of the frames, export.json "
              "engines_measured):");
          for (const auto& [name, e] : measured["engines"].items()) {
            if (e["rendered"].get<bool>())
              std::printf(" %s %.4f", name.c_str(), e["mean_abs_difference"].get<double>());
            else
              std::printf(" %s not rendered", name.c_str());
          }
          std::printf("\n");
        }
        for (const std::string& w : s.warnings)
          std::fprintf(stderr, "export: WARNING: %s\n", w.c_str());
        return 0;
      }};
}

}  // namespace aniso::cli
