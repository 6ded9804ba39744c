// aniso view: the interactive window (render/preview/viewer.h).
#include <filesystem>
#include <memory>

#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "render/bake/bake.h"
#include "render/bake/environment.h"
#include "render/preview/viewer.h"

namespace aniso::cli {

namespace {

struct ViewArgs {
  std::string input, size = "1024x768", shape, field, view, light, screenshot, env;
  int frames = 3;
  std::string show = "tables";
  bool force = false;
};

// A material file, a bake folder (its material and tables) or an export folder (its material).
Material read_view_input(const std::string& in, BakeFolder* bake) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(in, ec)) return read_material(in);
  if (fs::exists(fs::path(in) / "bake.json")) {
    *bake = read_bake(in);
    return bake->material;
  }
  const std::string ex = join_path(in, "export.json");
  if (!fs::exists(ex))
    throw Error(in +
                ": a folder to view must hold bake.json (aniso bake) or export.json "
                "(aniso export)");
  const auto j = jsonu::parse_file(read_text_file(ex), ex);
  if (!j.contains("material") || !j["material"].is_object()) throw Error(ex + ": no \"material\"");
  // The export's own files: its material's maps as it carries them (tables/maps/...), and its
  // line tables (tables/*.exr), drawn as an engine would draw them.
  jsonu::json mj = j["material"];
  const jsonu::json carried = j.value("maps", jsonu::json::object());
  for (const auto& [key, v] : carried.items()) {
    if (!v.is_object() || !v.contains("original") || !v["original"].is_string()) continue;
    const std::string file = v["original"];
    if (key == "topology.map")
      mj["topology"]["map"] = file;
    else if (key == "topology.s_map")
      mj["topology"]["s_map"] = file;
    else
      mj["maps"][key] = file;
  }
  Material m = material_from_json(mj, ex);
  m.base_dir = in;
  load_material_maps(ex, &m);
  const jsonu::json tables = j.value("tables", jsonu::json::object());
  auto table = [&](const char* key, int channels) {
    if (!tables.contains(key) || !tables[key].contains("exr"))
      throw Error(ex + ": tables." + key + ".exr: missing");
    const std::string f = join_path(in, tables[key]["exr"].get<std::string>());
    Image img = read_image(f).image;
    if (img.channels != channels || img.width != img.height)
      throw Error(f + ": expected a square table of " + std::to_string(channels) + " channel(s)");
    return img;
  };
  if (!m.fiber()) {
    BakeTables& t = bake->tables;
    t.diffuse = table("diffuse", 1);
    t.specular = table("specular", 1);
    t.combined = table("combined", 3);
    t.index = BakeIndex::kAngle;  // export.json conventions.line_tables
    t.size = t.diffuse.width;
    if (t.specular.width != t.size || t.combined.width != t.size)
      throw Error(ex + ": tables: diffuse, specular and combined differ in size");
  }
  return m;
}

}  // namespace

Command add_view(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  auto* v = app.add_subcommand(
      "view",
      "Interactive window: orbit, move the light, switch shape, terms, tables vs exact, "
      "error heat-map (needs a display; `xvfb-run -a` without one)");
  v->add_option("INPUT", a->input, "material file, bake folder or export folder")->required();
  v->add_option("--size", a->size, "window size WxH")->capture_default_str();
  v->add_option("--shape", a->shape,
                "sphere, disc, cylinder, torus or flat (default: flat for a material with maps, "
                "sphere otherwise)")
      ->check(CLI::IsMember({"sphere", "disc", "cylinder", "torus", "flat"}));
  v->add_option("--fiber-field", a->field, "replace dP/du: radial, circular or meridian")
      ->check(CLI::IsMember({"", "radial", "circular", "meridian"}));
  v->add_option("--view", a->view, "starting direction toward the viewer x,y,z");
  v->add_option("--light", a->light, "starting direction toward the light x,y,z");
  v->add_option("--env", a->env,
                "light from an equirectangular HDR environment (FILE.exr, z up), the built-in "
                "'studio' (the default where the preview's --env can light the material: every "
                "material but a second fiber beside a map of the fiber direction; unless --light "
                "is given) or 'none' (the light); the panel switches between the two");
  v->add_option("--screenshot", a->screenshot,
                "render, save the window (panel included) as this PNG and exit (scripted use)");
  add_force_flag(v, &a->force);
  v->add_option("--show", a->show,
                "starting display: tables (as an engine draws them), exact (the model on the "
                "CPU) or error (|tables - exact| x 10)")
      ->capture_default_str()
      ->check(CLI::IsMember({"tables", "exact", "error"}));
  v->add_option("--frames", a->frames, "frames drawn before --screenshot")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  return {v, [a] {
            BakeFolder bake;
            const Material m = read_view_input(a->input, &bake);
            ViewerOptions o;
            PreviewOptions& p = o.preview;
            p.progress = terminal_progress();
            parse_size(a->size, &p.width, &p.height);
            p.shape = default_shape(a->shape, m, "view");
            p.fiber_field = a->field;
            p.fill = 0.15;
            p.background = {0.03, 0.03, 0.03};
            if (!a->view.empty()) p.view_dir = parse_vec(a->view, "--view");
            if (!a->light.empty()) p.light_dirs = {parse_vec(a->light, "--light")};
            if (bake.tables.size > 0) {
              p.baked = &bake.tables;
              if (bake.has_fiber) p.baked_fiber = &bake.fiber;
              if (bake.has_stack) p.baked_stack = &bake.stack;
            }
            load_material_maps(m, "", &p);
            // The built-in studio by default where the material allows it and no light was
            // asked for; --env none keeps the light.
            Environment env;
            std::string env_name = a->env;
            const bool env_allowed = environment_unsupported(m) == nullptr;
            if (env_name.empty() && a->light.empty() && env_allowed) env_name = "studio";
            if (!env_name.empty() && env_name != "none") {
              env = named_environment(env_name);
              p.environment = &env;
            }
            o.screenshot = a->screenshot;
            o.screenshot_frames = a->frames;
            o.show = a->show == "exact" ? 1 : a->show == "error" ? 2 : 0;
            o.title = "aniso view: " + a->input;
            if (!o.screenshot.empty()) {
              check_outputs_apart({o.screenshot}, {a->input});
              check_output_file(o.screenshot, OutputKind::kScreenshot, a->force);
            }
            run_viewer(m, o);
            if (!o.screenshot.empty()) std::printf("view: wrote %s\n", o.screenshot.c_str());
            return 0;
          }};
}

}  // namespace aniso::cli
