// `aniso preview`: renders an object headless through OpenGL (EGL surfaceless on Mesa, no
// display) with the baked line-model texture the way Heidrich & Seidel do it (their §3-4):
// the fiber tangent T is the texture coordinate, a uniform texture matrix built from L and V turns
// it into (<L,T>, <V,T>), <N,L>^+ multiplies per fragment (self-shadowing), and each light (and
// each fiber direction) is one additive pass. Directional lights and a distant (orthographic)
// viewer keep L and V constant, as in the paper.
#pragma once
#include <string>
#include <vector>

#include "core/image.h"
#include "geometry/mesh.h"
#include "models/material.h"
#include "render/bake/bake.h"
#include "render/bake/environment.h"
#include "render/bake/environment_fiber.h"

namespace aniso {

class ProgressSink;  // core/progress.h

struct PreviewOptions {
  const ProgressSink* progress = nullptr;  // the bakes' bars (core/progress.h); null: silent
  std::string shape = "sphere";            // shape name or .obj path
  std::string fiber_field;                 // "", radial, circular, meridian
  ShapeOptions shape_options;
  int width = 512, height = 512;
  int table_size = 256;
  int table_index =
      1;  // 1 = angle index (default), 0 = the paper's cosine index (render/bake/bake.h)
  Vec3 view_dir{0.0, -0.8, 0.6};                   // toward the viewer
  std::vector<Vec3> light_dirs{{0.7, -0.2, 0.7}};  // toward each light; irradiance 1 each
  // A fill light from the viewer's direction with this irradiance (0: none), so the side the
  // lights miss keeps its silhouette; one more pass, shaded by the same model.
  double fill = 0;
  // Point lights at these positions (irradiance 1 at the object's centre, 1/d^2 around it), drawn
  // after the directional ones; L varies per fragment.
  std::vector<Vec3> point_lights;
  // A viewer at a finite distance (30 degree field of view framing the object) instead of the
  // paper's distant one: V varies per fragment, and a flat sample shows its streak.
  bool perspective = false;
  RGB background{0, 0, 0};  // linear radiance where no object is
  bool reference = false;   // also evaluate the model directly per pixel (CPU) for comparison
  bool plain = false;       // a plain textured-and-lit pass instead (for timing comparisons)
  // The paper's exact construction: texture coordinates from the texture matrix per vertex
  // (interpolated), the cosine-indexed table. Cheapest; errs where T bends across a triangle.
  bool per_vertex = false;
  int repeat = 1;  // frames to render (timing)
  // Render with the OpenGL context current on this thread (an interactive window's) instead of
  // making a headless one; the result is read back the same way.
  bool use_current_context = false;
  // Fiber model: the topology map (h in [0, 1], glTF uv) when the material uses one.
  Image topology_map;
  // Or a map of s itself (topology.s_map, what `fit --topology-map N` writes): channel 0 = s.
  Image s_map;
  // Render from these tables (a bake folder read back) instead of baking the material here.
  const BakeTables* baked = nullptr;
  const FiberBakeTables* baked_fiber = nullptr;
  const SpecularStack* baked_stack = nullptr;     // a material's map of n: the bake's stack
  const FiberStack* baked_fiber_stack = nullptr;  // and a fiber material's F over it
  // Light from this environment instead of the lights (the line model with one fiber, its maps of
  // k_d, k_s and the fiber direction but not of n; the fiber model with one topology s):
  // prefiltered once (render/bake/environment.h, environment_fiber.h), one pass; with `reference`
  // against brute force, the exact model summed over the environment's directions.
  const Environment* environment = nullptr;
  // Its prefiltered tables for this material (a material with maps: D's and S's apart), made once
  // for many frames (the interactive view, the turntable); prefiltered here when null.
  const EnvironmentTables* prefiltered = nullptr;
  const EnvironmentParts* prefiltered_parts = nullptr;
  const FiberEnvironmentTables* prefiltered_fiber = nullptr;    // a fiber material's
  const IsotropicEnvironment* prefiltered_isotropic = nullptr;  // an isotropic term's
};

struct PreviewResult {
  Image rgb;        // linear radiance, 3 channels
  Image reference;  // direct evaluation at the same fragments (when asked)
  std::vector<uint8_t> covered;
  int passes = 0;
  size_t triangles = 0;
  double seconds_per_frame = 0;
  double max_abs_diff = 0;        // |rgb - reference| over covered pixels (when asked)
  double error_bound = 0;         // what the bake's measured error and filtering allow
  double max_abs_diff_baked = 0;  // fiber model: against the same baked tables evaluated on the CPU
  // The fiber model with a map of n: the levels of F over its range, their bake time and the
  // whole lookup's measured error against the full model (render/bake/bake.h: FiberStack).
  int fiber_stack_levels = 0;
  double fiber_stack_seconds = 0, fiber_stack_error = 0, n_min = 0, n_max = 0;
  // An environment: the prefilter's time and sizes, and against brute force (`reference`) the
  // mean absolute difference and the relative RMS over covered pixels, and the directions summed.
  double env_prefilter_seconds = 0, env_reference_seconds = 0;
  EnvironmentTables env_sizes;  // (terms left empty)
  double env_mean_abs = 0, env_rel_rms = 0, env_reference_mean = 0;
  int env_reference_directions = 0;
  std::string renderer;  // GL_RENDERER
  int frames = 0;        // frames timed (PreviewOptions::repeat, at least 1)
};

PreviewResult render_preview(const Material& m, const PreviewOptions& opt);

// What render_preview bakes for a material (the line tables; the fiber model's factor tables; with
// a map of n the stacks over its range), baked once for many frames of one material (a turntable,
// the interactive view): each that `p` does not already point to is baked into `keep` and `p`
// pointed to it.
struct PreviewBakes {
  BakeTables tables;
  FiberBakeTables fiber;
  SpecularStack stack;
  FiberStack fiber_stack;
};
void bake_for_frames(const Material& m, PreviewOptions* p, PreviewBakes* keep);

// The environment of `p` prefiltered once for many frames of `m` (after bake_for_frames): what
// render_preview would otherwise prefilter at every frame.
struct PreviewPrefiltered {
  EnvironmentTables tables;
  EnvironmentParts parts;
  FiberEnvironmentTables fiber;
  IsotropicEnvironment isotropic;
};
void prefilter_for_frames(const Material& m, PreviewOptions* p, PreviewPrefiltered* keep);

// The lights a preview draws: each of light_dirs with irradiance 1, the fill light, then the
// point lights (irradiance 1 at `center`).
struct PreviewLight {
  Vec3 dir;  // unit, toward the light (directional)
  double irradiance = 1;
  bool point = false;
  Vec3 pos;       // point light: where it is
  double d0 = 1;  // point light: distance at which the irradiance is `irradiance`
  // Direction toward the light and irradiance at P.
  void at(const Vec3& P, Vec3* L, double* E) const;
};
std::vector<PreviewLight> preview_lights(const PreviewOptions& opt, const Vec3& center);

}  // namespace aniso
