#include "render/export/export_environment.h"

#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/ktx2.h"
#include "render/bake/environment_fiber.h"
#include "render/shaders_embedded.h"

namespace aniso {

using nlohmann::json;

namespace {

// The line model's: the environment's prefiltered terms as seven RGBA16F 2D arrays (a layer per
// level of <V,T>: the volumes shaders/aniso_environment.glsl samples) beside that file, and their
// entry in export.json's tables. Half floats: their rounding (2^-11 relative) is far under the
// prefilter's own error against brute force, they filter in every WebGL 2, and the terms take half
// the bytes.
json write_line_environment(const std::string& dir, const Environment& env, ExportSummary* sum) {
  const EnvironmentTables et = prefilter_environment(env, sum->line);
  json files = json::array();
  for (int t = 0; t < 7; ++t) {
    KtxTexture k;
    k.format = KtxFormat::kRGBA16Float;
    k.width = et.w, k.height = et.h, k.layers = et.nb;
    k.texels.resize(static_cast<size_t>(et.w) * et.h * et.nb * 4);
    for (size_t p = 0; p < k.texels.size() / 4; ++p) {
      for (int c = 0; c < 3; ++c) k.texels[4 * p + c] = et.terms[t][3 * p + c];
      k.texels[4 * p + 3] = 1.f;
    }
    k.metadata["aniso.meaning"] = "environment term " + std::to_string(t);
    const std::string name = "tables/environment_t" + std::to_string(t) + ".ktx2";
    write_ktx2(join_path(dir, name), k);
    sum->files.push_back(name);
    files.push_back(name);
  }
  write_text_file(join_path(dir, "shaders/aniso_environment.glsl"),
                  shaders::aniso_environment_glsl);
  sum->files.push_back("shaders/aniso_environment.glsl");
  sum->environment_seconds = et.seconds;
  return {{"source", env.name},
          {"model", "line"},
          {"shader", "shaders/aniso_environment.glsl"},
          {"terms", files},
          {"size", {et.w, et.h}},
          {"layers", et.nb},
          {"cells", {et.env_w, et.env_h}},
          {"lookup",
           "T, the fiber: s = atan2(T.y, T.x) / 2 pi (repeat), t = acos(T.z) / pi; layer: b = "
           "<V,T> at acos(-b) = pi k / (layers - 1), linear between layers; radiance = t0 + c t1 + "
           "s t2 + (c^2 - s^2) t3 + 2 c s t4 + cos 4chi t5 + sin 4chi t6, with (c, s) = (<N,e1>, "
           "<N,e2>), e1 = normalize(z x T) (x x T near z), e2 = T x e1: "
           "shaders/aniso_environment.glsl's anisoEnvironmentRadiance"},
          {"seconds", et.seconds}};
}

// The fiber model's (render/bake/environment_fiber.h): D's terms, S's terms (their levels of b side
// by side) and the coefficients over (phi_v, b) as three 2D arrays whose layers are the volumes'
// depth, beside shaders/aniso_environment_fiber.glsl. D's and S's terms in half floats as the line
// model's; the coefficients, small and summed with cancellation, in 32-bit floats.
json write_fiber_environment(const std::string& dir, const Material& m, const Environment& env,
                             ExportSummary* sum) {
  const FiberEnvironmentTables ft =
      prefilter_fiber_environment(env, m, sum->line, sum->fiber_tables);
  json files = json::object();
  auto write = [&](const std::string& key, KtxFormat format, int w, int h, int layers,
                   const std::vector<float>& rgb, const std::string& meaning) {
    KtxTexture k;
    k.format = format;
    k.width = w, k.height = h, k.layers = layers;
    k.texels.resize(static_cast<size_t>(w) * h * layers * 4);
    for (size_t p = 0; p < k.texels.size() / 4; ++p) {
      for (int c = 0; c < 3; ++c) k.texels[4 * p + c] = rgb[3 * p + c];
      k.texels[4 * p + 3] = 1.f;
    }
    k.metadata["aniso.meaning"] = meaning;
    const std::string name = "tables/fiber_environment_" + key + ".ktx2";
    write_ktx2(join_path(dir, name), k);
    sum->files.push_back(name);
    files[key] = name;
  };
  const int nt = ft.terms();
  write("D", KtxFormat::kRGBA16Float, ft.w, ft.h, nt, ft.diffuse,
        "fiber model under an environment: D's terms");
  write("S", KtxFormat::kRGBA16Float, ft.w, ft.h * ft.nn, nt * ft.nb,
        fiber_environment_specular_volume(ft),
        "fiber model under an environment: S's terms, levels of b side by side");
  write("coef", KtxFormat::kRGBA32Float, ft.nphi, ft.nb, ft.coef_layers() * ft.ns * ft.nn,
        fiber_environment_coef_volume(ft),
        "fiber model under an environment: F's and G's coefficients over (phi_v, b, s)");
  write_text_file(join_path(dir, "shaders/aniso_environment_fiber.glsl"),
                  shaders::aniso_environment_fiber_glsl);
  sum->files.push_back("shaders/aniso_environment_fiber.glsl");
  sum->environment_seconds = ft.seconds;
  return {{"source", env.name},
          {"model", "fiber"},
          {"shader", "shaders/aniso_environment_fiber.glsl"},
          {"tables", files},
          {"size", {ft.w, ft.h}},
          {"order", ft.order},
          {"layers", ft.nb},
          {"phis", ft.nphi},
          {"s_levels", ft.ns},
          {"cells", {ft.env_w, ft.env_h}},
          {"lookup",
           "each table a volume (its layers the depth; D's and S's repeat round s); "
           "shaders/aniso_environment_fiber.glsl's anisoFiberEnvironmentRadiance(N, T, V, s, k_d, "
           "k_s) with anisoFibEnvOrder = order, anisoFibEnvLevels = layers, anisoFibEnvPhis = "
           "phis, anisoFibEnvSLevels = s_levels"},
          {"seconds", ft.seconds}};
}

}  // namespace

json write_environment(const std::string& dir, const Material& m, const Environment& env,
                       ExportSummary* sum) {
  if (const std::string why = environment_refusal(m); !why.empty())
    throw Error("export: --env " + env.name + ": " + why);
  return m.fiber() ? write_fiber_environment(dir, m, env, sum)
                   : write_line_environment(dir, env, sum);
}

std::string environment_refusal(const Material& m) {
  // The export's viewer draws one lobe without maps under an environment, the fiber model at one
  // s or the sample sphere's mathematical topology: not what the preview's prefilters cover beyond
  // it.
  const bool fiber_topology =
      m.topology_as<UniformS>() ||
      (m.topology_as<MathematicalS>() && m.mathematical() == MathTopology::kSphere);
  const char* what = m.maps.any()           ? "maps"
                     : m.second_active()    ? "a second fiber"
                     : m.isotropic_active() ? "an isotropic term"
                     : m.fiber() && !fiber_topology
                         ? "a topology map, a map of s or a torus's topology"
                         : environment_unsupported(m);
  if (!what) return "";
  return "the export's viewer lights the line and the fiber model with one fiber, no maps and no "
         "isotropic term under an environment (aniso preview --env and aniso view light more); "
         "this material has " +
         std::string(what);
}

}  // namespace aniso
