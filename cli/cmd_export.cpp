// aniso export: tables, shaders and glTF for engines and browsers (render/export/export.h).
#include <cstdio>
#include <cstring>
#include <memory>

#include "cli/command.h"
#include "core/angles.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "render/export/export.h"

namespace aniso::cli {

Command add_export(CLI::App& app) {
  struct Args {
    std::string mat, out, env;
    int size = 256;
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
  add_force_flag(ex);
  ex->add_option("--env", a->env,
                 "also prefilter an equirectangular HDR environment (FILE.exr, z up) or the "
                 "built-in 'studio' for the material: the browser viewer then lights with it");
  ex->add_option("--size", a->size, "line tables N x N")
      ->capture_default_str()
      ->check(CLI::Range(2, 8192));
  return {
      ex, [a] {
        const Material m = read_material(a->mat);
        check_outputs_apart({a->out}, material_input_files(m, a->mat));
        ExportOptions o;
        o.size = a->size;
        o.command = shareable_command_line(a->out);
        Environment env;
        if (!a->env.empty()) {
          env = named_environment(a->env);
          o.environment = &env;
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
        if (o.environment)
          std::printf(
              "  environment %s prefiltered in %.2f s: tables/environment_t0..6.ktx2 (the "
              "browser viewer lights with it: viewer.html?env=1)\n",
              env.name.c_str(), s.environment_seconds);
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
        for (const std::string& w : s.warnings)
          std::fprintf(stderr, "export: WARNING: %s\n", w.c_str());
        return 0;
      }};
}

}  // namespace aniso::cli
