// `aniso export`: what a game engine, a glTF viewer or a browser loads, in one folder.
//   tables/   every lookup table the material needs as KTX2 (float, one level, no
//             supercompression; fiber factor tables as 2D arrays, no side over 8192) and EXR;
//             the material's maps as KTX2 beside copies of the originals
//   shaders/  the lookup as GLSL (function file + complete #version 330 fragment shader) and HLSL
//             (function file + complete pixel shader); fiber materials also the factor tables;
//             materials with maps of k_d, k_s, n or the fiber direction also the maps' lookup
//             (with a line material's map of n, S from a stack of tables over its range)
//   gltf/     a sphere with tangents carrying the material as glTF 2.0 metallic-roughness plus
//             KHR_materials_anisotropy, fitted numerically (render/export/gltf_lobe.h); the exact
//             model and the tables under extras
//   three/    viewer.html and an ES module that draws the material in three.js from the KTX2
//             tables (and three itself, copied so the folder works offline)
//   engines/  packages for Godot 4, Unity and Unreal (a line material:
//   render/export/export_engines.h) export.json  what was written, the conventions an integrator
//   needs and the measured errors
#pragma once
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "models/material.h"
#include "render/bake/bake.h"
#include "render/bake/environment.h"
#include "render/export/gltf_lobe.h"

namespace aniso {

class ProgressSink;  // core/progress.h

struct ExportOptions {
  int size = 256;                          // line tables N x N
  std::string command;                     // recorded in export.json
  const ProgressSink* progress = nullptr;  // its bar: tables, maps, shaders, glTF, viewer
  // --env: this environment prefiltered for the material (render/bake/environment.h) as
  // tables/environment_t0..6.ktx2, which the browser viewer lights with (a line material with one
  // fiber and no maps: environment_refusal). With `environment_where_it_applies` a material it does
  // not apply to is exported without it, export.json saying why (the CLI's default studio);
  // otherwise it is an error.
  const Environment* environment = nullptr;
  bool environment_where_it_applies = false;
  // Called with the export's folder as written so far (everything but export.json), before it
  // replaces the output: what it returns goes into export.json as "engines_measured" (the CLI's
  // --engines renders the glTF with real engines there; null: nothing added).
  std::function<nlohmann::json(const std::string& dir)> measure_engines;
};

// Which maps the exported shaders sample (aniso_maps.glsl's defines) and, with a map of n, the
// stack of specular tables they blend.
struct ExportMapSet {
  bool kd = false, ks = false, n = false, fiber = false;
  int levels = 0;  // the stack's (map of n only)
  double log_n0 = 0, log_step = 0;
  int f_levels = 0;  // a fiber material's map of n: F's levels (render/bake/bake.h: FiberStack)
  double f_log_n0 = 0, f_log_step = 0;
  // The fiber model's topology over uv: a map of s, or a topology map h with its amplitude (one
  // value, or a map of it).
  bool s_map = false, topology_map = false, amplitude = false;
  double topology_amplitude = 0;
  bool any() const { return kd || ks || n || fiber || s_map || topology_map || amplitude; }
};

struct ExportSummary {
  BakeTables line;  // sizes and measured errors (texels dropped)
  bool fiber = false;
  FiberBakeTables fiber_tables;
  GltfPbr pbr;  // the mean material's (its factors where there are no per-texel textures)
  // A material with maps of k_d, k_s or n: the glTF's per-texel textures (w = 0: none).
  struct {
    int w = 0, h = 0, nodes = 0;
    double worst_rel_rms = 0;
    std::string mapping;  // the one mapping of every texel, and the errors of the three
    bool specular = false;
  } gltf_texels;
  ExportMapSet maps;                  // what the shaders and the browser viewer draw per texel
  double stack_max_abs_error = 0;     // the stack's lookup against S (map of n only)
  FiberStack fiber_stack;             // F's levels: texels dropped, sizes and error kept
  std::vector<std::string> files;     // relative to the export folder
  std::vector<std::string> warnings;  // said to the user and recorded in export.json
  double seconds = 0;
  double environment_seconds = 0;    // --env: the prefilter's
  std::string environment_left_out;  // why the environment was not written ("" if it was)
};

// Why the export cannot carry an environment for `m` ("" where it can): its viewer lights the line
// model's one lobe, without maps or an isotropic term.
std::string environment_refusal(const Material& m);

// Writes the folder atomically: new, empty, or an earlier export holding exactly what it wrote
// (io/files/files.h); anything else is refused, or with --force moved aside.
ExportSummary export_material(const Material& m, const std::string& dir, const ExportOptions& o);

// The shader sources as exported (the function files with ANISO_TEXELS defined, and the complete
// shaders that inline them), for the tests and for `aniso export`.
struct ExportShaders {
  std::string glsl_lookup, glsl_fragment, hlsl_lookup, hlsl_pixel;
  // Fiber model: the factor-table functions (after the lookup files) and complete shaders that
  // use them; empty for the line model.
  std::string glsl_fiber, glsl_fiber_fragment, hlsl_fiber, hlsl_fiber_pixel;
  // Maps (ExportMapSet::any): aniso_maps.glsl/.hlsli after the lookup files with the maps'
  // defines, and complete shaders that draw the line model from them.
  std::string glsl_maps, glsl_maps_fragment, hlsl_maps, hlsl_maps_pixel;
};
ExportShaders export_shaders(int texels, const FiberBakeTables* fiber = nullptr,
                             const ExportMapSet* maps = nullptr);

}  // namespace aniso
