// aniso preview: a headless OpenGL render of a material on an object.
#include <cmath>
#include <cstdio>
#include <memory>

#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "render/bake/bake.h"
#include "render/preview/preview.h"

namespace aniso::cli {

namespace {
// A person's default: a dim grey background (linear 0.03, sRGB 48/255) and a fill light from the
// viewer of irradiance 0.15, so the unlit side keeps its silhouette. --background 0 --fill 0 give
// the bare render.
constexpr double kDefaultFill = 0.15;

RGB parse_background(const std::string& s) {
  double v[3];
  char extra;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &extra) == 3)
    return {v[0], v[1], v[2]};
  if (std::sscanf(s.c_str(), "%lf%c", &v[0], &extra) == 1) return {v[0], v[0], v[0]};
  throw Error("preview: --background must be a linear grey level or r,g,b (got '" + s + "')");
}

Vec3 parse_point(const std::string& s) {
  double v[3];
  char extra;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &extra) != 3 ||
      !std::isfinite(v[0] + v[1] + v[2]))
    throw Error("preview: --point-light must be a position x,y,z (got '" + s + "')");
  return Vec3(v[0], v[1], v[2]);
}

// --turntable N: N views turned about the z axis, side by side.
Image turntable(const Material& m, PreviewOptions p, int n, PreviewResult* last) {
  Image sheet(p.width * n, p.height, 3);
  const Vec3 v0 = p.view_dir;
  PreviewBakes bakes;  // one material: its tables baked once for every frame
  Progress bar("preview --turntable: the tables, then " + std::to_string(n) + " frames", n + 1,
               terminal_progress());
  bake_for_frames(m, &p, &bakes);
  PreviewPrefiltered prefiltered;  // an environment: prefiltered once too
  prefilter_for_frames(m, &p, &prefiltered);
  bar.advance();
  for (int i = 0; i < n; ++i, bar.advance()) {
    const double a = 2 * M_PI * i / n, c = std::cos(a), s = std::sin(a);
    p.view_dir = Vec3(c * v0.x - s * v0.y, s * v0.x + c * v0.y, v0.z);
    *last = render_preview(m, p);
    for (int y = 0; y < p.height; ++y)
      for (int x = 0; x < p.width; ++x)
        for (int k = 0; k < 3; ++k) sheet.at(i * p.width + x, y, k) = last->rgb.at(x, y, k);
  }
  return sheet;
}

struct PreviewArgs {
  std::string mat, bake, out, shape, field, size = "512x512", view, exr, map, index = "angle", env;
  std::vector<std::string> lights, point_lights;
  bool perspective = false;
  double exposure = 1.0, R = 1.0, r = 0.6;
  double fill = kDefaultFill;
  std::string background = "0.03";
  int table = 256, turntable = 0;
  bool per_vertex = false;
  bool env_check = false;
  bool force = false;
};

// Brute force under an environment costs the image's pixels times 8192 directions: checked by
// default up to this many pixels (256 x 256), beyond it with --env-check.
constexpr long kEnvCheckPixels = 65536;
// The fiber model's exact evaluation integrates over each fibre's cross-section: its brute force
// takes about 0.9 ms a pixel on two cores, so by default it checks frames up to 64 x 64.
constexpr long kEnvCheckPixelsFiber = 4096;

int run(const PreviewArgs& a) {
  if (a.mat.empty() == a.bake.empty())
    throw Error("preview: give a MATERIAL file or --bake DIR (one of them)");
  // From a bake folder: its material and the very tables written there (read back, not re-baked).
  BakeFolder bake;
  if (!a.bake.empty()) bake = read_bake(a.bake);
  const Material m = a.bake.empty() ? read_material(a.mat) : bake.material;
  std::vector<std::string> inputs =
      a.bake.empty() ? material_input_files(m, a.mat) : std::vector<std::string>{a.bake};
  inputs.push_back(a.map);
  if (lower_ext(a.shape) == ".obj") inputs.push_back(a.shape);
  check_outputs_apart({a.out, a.exr}, inputs);
  const std::string ext = lower_ext(a.out);
  if (a.out != "-" && ext != ".png" && ext != ".exr" && ext != ".jpg" && ext != ".jpeg")
    throw Error("preview: --out " + a.out +
                ": writes .png (8-bit sRGB), .jpg (sRGB) or .exr "
                "(linear float); give one of those extensions");
  check_output_file(a.out, OutputKind::kPreview, a.force);
  if (!a.exr.empty()) {
    if (lower_ext(a.exr) != ".exr") throw Error("preview: --exr " + a.exr + ": give a .exr name");
    check_output_file(a.exr, OutputKind::kPreview, a.force);
  }
  PreviewOptions p;
  p.progress = terminal_progress();
  p.shape = default_shape(a.shape, m, "preview");
  p.fiber_field = a.field;
  parse_size(a.size, &p.width, &p.height);
  p.table_size = a.table;
  p.table_index = parse_index(a.index) == BakeIndex::kAngle ? 1 : 0;
  p.per_vertex = a.per_vertex;
  if (!a.view.empty()) p.view_dir = parse_vec(a.view, "--view");
  if (!a.lights.empty()) {
    p.light_dirs.clear();
    for (const auto& l : a.lights) p.light_dirs.push_back(parse_vec(l, "--light"));
  }
  p.reference = true;
  if (!a.bake.empty()) {
    p.baked = &bake.tables;
    if (bake.has_fiber) p.baked_fiber = &bake.fiber;
    if (bake.has_stack) p.baked_stack = &bake.stack;
  }
  load_material_maps(m, a.map, &p);
  p.shape_options.torus_R = a.R;
  p.shape_options.torus_r = a.r;
  p.fill = a.fill;
  p.perspective = a.perspective;
  for (const auto& l : a.point_lights) p.point_lights.push_back(parse_point(l));
  // Point lights replace the default directional light unless --light is given too.
  if (!a.point_lights.empty() && a.lights.empty()) p.light_dirs.clear();
  Environment env;
  if (!a.env.empty()) {
    env = named_environment(a.env);
    p.environment = &env;
    p.reference = a.env_check || static_cast<long>(p.width) * p.height <=
                                     (m.fiber() ? kEnvCheckPixelsFiber : kEnvCheckPixels);
  }
  p.background = parse_background(a.background);
  for (double v : p.background)
    if (!(v >= 0 && v <= 1e6)) throw Error("preview: --background values must be in [0, 1e6]");
  PreviewResult r;
  const Image img =
      a.turntable > 0 ? turntable(m, p, a.turntable, &r) : (r = render_preview(m, p)).rgb;
  // An .exr output is the linear float image; anything else an 8-bit sRGB PNG.
  if (ext == ".exr")
    write_exr(a.out, img);
  else if (ext == ".jpg" || ext == ".jpeg")
    write_jpeg(a.out, encode_srgb(img, a.exposure));
  else
    write_png(a.out, encode_srgb(img, a.exposure), 8);
  if (!a.exr.empty()) write_exr(a.exr, img);
  if (p.environment && !p.reference) {
    std::fprintf(
        stderr,
        "preview: %s under the environment %s, %zu triangles, %d pass, %.2f ms/frame on %s "
        "-> %s; prefiltered (%dx%d directions of T, %d levels of <V,T>) in %.2f s; not held "
        "against brute force above %ld pixels (--env-check does)\n",
        p.shape.c_str(), env.name.c_str(), r.triangles, r.passes, 1e3 * r.seconds_per_frame,
        r.renderer.c_str(), a.out.c_str(), r.env_sizes.w, r.env_sizes.h, r.env_sizes.nb,
        r.env_prefilter_seconds, m.fiber() ? kEnvCheckPixelsFiber : kEnvCheckPixels);
    return 0;
  }
  if (p.environment) {
    std::fprintf(
        stderr,
        "preview: %s under the environment %s, %zu triangles, %d pass, %.2f ms/frame on %s "
        "-> %s; prefiltered (%dx%d directions of T, %d levels of <V,T>, from %dx%d "
        "environment cells) in %.2f s; against brute force (the exact model over %d "
        "directions, %.2f s): mean abs difference %.3g (mean value %.3g), "
        "relative RMS %.3g, max %.3g\n",
        p.shape.c_str(), env.name.c_str(), r.triangles, r.passes, 1e3 * r.seconds_per_frame,
        r.renderer.c_str(), a.out.c_str(), r.env_sizes.w, r.env_sizes.h, r.env_sizes.nb,
        r.env_sizes.env_w, r.env_sizes.env_h, r.env_prefilter_seconds, r.env_reference_directions,
        r.env_reference_seconds, r.env_mean_abs, r.env_reference_mean, r.env_rel_rms,
        r.max_abs_diff);
    return 0;
  }
  std::fprintf(stderr,
               "preview: %s, %zu triangles, %d passes, %.2f ms/frame on %s -> %s; baked vs direct "
               "evaluation: max abs difference %.3g (bound %.3g)",
               p.shape.c_str(), r.triangles, r.passes, 1e3 * r.seconds_per_frame,
               r.renderer.c_str(), a.out.c_str(), r.max_abs_diff, r.error_bound);
  if (m.fiber())
    std::fprintf(stderr, "; GPU vs the same tables on the CPU: %.3g", r.max_abs_diff_baked);
  if (r.fiber_stack_levels > 0)
    std::fprintf(stderr,
                 "; map of n (%.4g to %.4g) drawn per fragment: F from %d levels over log n (baked "
                 "in %.2f s), S from the specular stack; vs the full model max abs %.3g",
                 r.n_min, r.n_max, r.fiber_stack_levels, r.fiber_stack_seconds,
                 r.fiber_stack_error);
  std::fprintf(stderr, "\n");
  return 0;
}
}  // namespace

Command add_preview(CLI::App& app) {
  auto a = std::make_shared<PreviewArgs>();
  auto* prev = app.add_subcommand(
      "preview", "Render an object headless through OpenGL with the baked texture");
  prev->footer(
      "Renderer: a GPU's EGL device where EGL lists one, else EGL's surfaceless platform (Mesa: "
      "a GPU's render node or llvmpipe on the CPU). The environment variable ANISO_GL=auto (the "
      "default), gpu (a GPU's device or an error) or software (Mesa's llvmpipe or an error) "
      "chooses. The line printed names the renderer used.");
  prev->add_option("MATERIAL", a->mat, "material file (or --bake)");
  prev->add_option("--bake", a->bake,
                   "render from a bake folder (what `aniso bake` wrote: its material and tables, "
                   "read back as an engine would)");
  prev->add_option("--out", a->out,
                   "image to write: .exr = linear float, otherwise an 8-bit sRGB PNG ('-' = "
                   "standard output)")
      ->required();
  prev->add_option("--background", a->background,
                   "linear background: a grey level or r,g,b (0 = black)")
      ->capture_default_str();
  prev->add_option("--env", a->env,
                   "light from an equirectangular HDR environment (FILE.exr, z up, twice as wide "
                   "as high) or the built-in 'studio', instead of the lights: prefiltered for the "
                   "line model (with its maps, a second fiber, an isotropic term) or the fiber "
                   "model (any topology, the same maps and terms) and drawn in one pass, then "
                   "held against brute force");
  prev->add_flag("--env-check", a->env_check,
                 "--env: hold the frame against brute force whatever its size (by default up to "
                 "256x256 pixels, 64x64 for the fiber model)");
  prev->add_option("--fill", a->fill,
                   "irradiance of a fill light from the viewer (0 = none); lights are 1 each")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  prev->add_option("--point-light", a->point_lights,
                   "a point light at x,y,z (irradiance 1 at the object's centre, 1/d^2 around; "
                   "repeat for more; replaces the default light unless --light is given)");
  prev->add_flag("--perspective", a->perspective,
                 "a viewer at a finite distance (30 deg field of view) instead of a distant one");
  prev->add_option("--turntable", a->turntable,
                   "N views turned about z, side by side in one image (a contact sheet)")
      ->check(CLI::Range(1, 64));
  prev->add_option("--shape", a->shape,
                   "sphere, disc, cylinder, torus, flat, or an .obj file (default: flat for a "
                   "material with maps, where a sphere wraps them with a seam; sphere otherwise)");
  prev->add_option("--fiber-field", a->field, "replace dP/du: radial, circular or meridian")
      ->check(CLI::IsMember({"", "radial", "circular", "meridian"}));
  prev->add_option("--size", a->size, "image size WxH")->capture_default_str();
  prev->add_option("--light", a->lights,
                   "direction toward a light x,y,z (repeat for more lights; one pass each)");
  prev->add_option("--view", a->view, "direction toward the viewer x,y,z");
  prev->add_option("--exposure", a->exposure, "scale before sRGB encoding")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  prev->add_option("--table-size", a->table, "lookup table size")
      ->capture_default_str()
      ->check(CLI::Range(2, 8192));
  prev->add_option("--exr", a->exr, "also write the linear float image here");
  add_force_flag(prev, &a->force);
  prev->add_flag("--per-vertex", a->per_vertex,
                 "the paper's construction exactly: texture matrix per vertex, cosine table");
  prev->add_option("--topology-map", a->map,
                   "fiber model: topology map image (default: the material's, relative to it)");
  prev->add_option("--torus-R", a->R, "torus major radius (shape torus)")->capture_default_str();
  prev->add_option("--torus-r", a->r, "torus minor radius (shape torus)")->capture_default_str();
  prev->add_option("--index", a->index, "lookup table spacing: angle or cosine (see bake --help)")
      ->capture_default_str()
      ->check(CLI::IsMember({"angle", "cosine"}));
  return {prev, [a] { return run(*a); }};
}

}  // namespace aniso::cli
