#include "render/export/export_environment.h"

#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/ktx2.h"
#include "render/bake/environment_fiber.h"
#include "render/shaders_embedded.h"

namespace aniso {

using nlohmann::json;

namespace {

// One table as a KTX2 2D array (its layers a volume's depth for the shaders): RGB in, alpha 1.
// Half floats for the terms (their rounding, 2^-11 relative, is far under the prefilter's own error
// against brute force; they filter in every WebGL 2 and take half the bytes); 32-bit floats where
// values are summed with cancellation (the fiber model's coefficients).
std::string write_volume(const std::string& dir, const std::string& name, KtxFormat format, int w,
                         int h, int layers, const std::vector<float>& rgb,
                         const std::string& meaning, ExportSummary* sum) {
  KtxTexture k;
  k.format = format;
  k.width = w, k.height = h, k.layers = layers;
  k.texels.resize(static_cast<size_t>(w) * h * layers * 4);
  for (size_t p = 0; p < k.texels.size() / 4; ++p) {
    for (int c = 0; c < 3; ++c) k.texels[4 * p + c] = rgb[3 * p + c];
    k.texels[4 * p + 3] = 1.f;
  }
  k.metadata["aniso.meaning"] = meaning;
  const std::string path = "tables/" + name + ".ktx2";
  write_ktx2(join_path(dir, path), k);
  sum->files.push_back(path);
  return path;
}

void write_shader(const std::string& dir, const std::string& name, const char* text,
                  ExportSummary* sum) {
  write_text_file(join_path(dir, "shaders/" + name), text);
  sum->files.push_back("shaders/" + name);
}

// The line model with one k_d and k_s: the environment's prefiltered terms as seven 2D arrays (a
// layer per level of <V,T>: the volumes shaders/aniso_environment.glsl samples).
json write_line_environment(const std::string& dir, const Environment& env, ExportSummary* sum) {
  const EnvironmentTables et = prefilter_environment(env, sum->line);
  json files = json::array();
  for (int t = 0; t < 7; ++t)
    files.push_back(write_volume(dir, "environment_t" + std::to_string(t), KtxFormat::kRGBA16Float,
                                 et.w, et.h, et.nb, et.terms[t],
                                 "environment term " + std::to_string(t), sum));
  write_shader(dir, "aniso_environment.glsl", shaders::aniso_environment_glsl, sum);
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

// A line material with maps: D's and S's terms apart at unit k_d and k_s (with a map of n, S at
// levels of n), two volumes beside shaders/aniso_environment_parts.glsl.
json write_line_parts_environment(const std::string& dir, const Material& m, const Environment& env,
                                  ExportSummary* sum) {
  const EnvironmentParts parts = prefilter_environment_parts(env, sum->line, &m);
  const EnvironmentTables& et = parts.diffuse;
  const int levels = std::max<int>(1, static_cast<int>(parts.specular_n.size()));
  json files = json::object();
  files["D"] = write_volume(dir, "environment_parts_D", KtxFormat::kRGBA16Float, et.w, et.h,
                            7 * et.nb, environment_parts_d_volume(parts),
                            "environment, D's seven terms, levels of b side by side", sum);
  files["S"] = write_volume(dir, "environment_parts_S", KtxFormat::kRGBA16Float, et.w,
                            et.h * levels, 7 * et.nb, environment_parts_s_volume(parts),
                            "environment, S's seven terms, levels of n one above the other", sum);
  write_shader(dir, "aniso_environment.glsl", shaders::aniso_environment_glsl, sum);
  write_shader(dir, "aniso_environment_parts.glsl", shaders::aniso_environment_parts_glsl, sum);
  sum->environment_seconds = et.seconds + parts.specular.seconds;
  return {{"source", env.name},
          {"model", "line"},
          {"shader", "shaders/aniso_environment.glsl"},
          {"parts_shader", "shaders/aniso_environment_parts.glsl"},
          {"parts", files},
          {"size", {et.w, et.h}},
          {"layers", et.nb},
          {"n_levels", levels},
          {"log_n0", parts.logn0},
          {"log_step", parts.log_step},
          {"cells", {et.env_w, et.env_h}},
          {"lookup",
           "each table a volume (its layers the depth, repeating round s); after "
           "shaders/aniso_environment.glsl, shaders/aniso_environment_parts.glsl's "
           "anisoEnvironmentParts(N, T, V, n, d, s) with anisoEnvLevels = layers, "
           "anisoEnvPartRows = size[1], anisoEnvPartNLevels = n_levels, anisoEnvPartLogN0 = "
           "log_n0, anisoEnvPartLogStep = log_step; radiance = k_d d + k_s s at the fragment's "
           "k_d, k_s and n"},
          {"seconds", sum->environment_seconds}};
}

// The fiber model's (render/bake/environment_fiber.h): D's terms, S's terms (their levels of b side
// by side, levels of n one above the other) and the coefficients over (phi_v, b, s, n) as three
// volumes beside shaders/aniso_environment_fiber.glsl.
json write_fiber_environment(const std::string& dir, const Material& m, const Environment& env,
                             ExportSummary* sum) {
  const FiberEnvironmentTables ft =
      prefilter_fiber_environment(env, m, sum->line, sum->fiber_tables);
  const int nt = ft.terms();
  json files = json::object();
  files["D"] = write_volume(dir, "fiber_environment_D", KtxFormat::kRGBA16Float, ft.w, ft.h, nt,
                            ft.diffuse, "fiber model under an environment: D's terms", sum);
  files["S"] = write_volume(dir, "fiber_environment_S", KtxFormat::kRGBA16Float, ft.w, ft.h * ft.nn,
                            nt * ft.nb, fiber_environment_specular_volume(ft),
                            "fiber model under an environment: S's terms", sum);
  files["coef"] = write_volume(
      dir, "fiber_environment_coef", KtxFormat::kRGBA32Float, ft.nphi, ft.nb,
      ft.coef_layers() * ft.ns * ft.nn, fiber_environment_coef_volume(ft),
      "fiber model under an environment: F's and G's coefficients over (phi_v, b, s, n)", sum);
  write_shader(dir, "aniso_environment_fiber.glsl", shaders::aniso_environment_fiber_glsl, sum);
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
          {"n_levels", ft.nn},
          {"log_n0", ft.logn0},
          {"log_step", ft.log_step},
          {"cells", {ft.env_w, ft.env_h}},
          {"lookup",
           "each table a volume (its layers the depth; D's and S's repeat round s); "
           "shaders/aniso_environment_fiber.glsl's anisoFiberEnvironmentRadiance(N, T, V, s, n, "
           "k_d, k_s) with anisoFibEnvOrder = order, anisoFibEnvLevels = layers, anisoFibEnvPhis "
           "= phis, anisoFibEnvSLevels = s_levels, anisoFibEnvNLevels = n_levels, "
           "anisoFibEnvLogN0 = log_n0, anisoFibEnvLogStep = log_step, anisoFibEnvRows = size[1]"},
          {"seconds", ft.seconds}};
}

// The isotropic term's two tables and its factor over <N,V>, beside
// shaders/aniso_environment_isotropic.glsl.
json write_isotropic_environment(const std::string& dir, const Material& m, const Environment& env,
                                 ExportSummary* sum) {
  const IsotropicEnvironment it = prefilter_isotropic_environment(env, m.iso_n);
  json files = json::object();
  files["irradiance"] =
      write_volume(dir, "environment_isotropic_irradiance", KtxFormat::kRGBA16Float, it.w, it.h, 1,
                   it.irradiance, "environment, the irradiance over N", sum);
  files["glossy"] =
      write_volume(dir, "environment_isotropic_glossy", KtxFormat::kRGBA16Float, it.w, it.h, 1,
                   it.glossy, "environment, the Phong lobe of n_iso / 4 over R", sum);
  write_shader(dir, "aniso_environment_isotropic.glsl", shaders::aniso_environment_isotropic_glsl,
               sum);
  sum->environment_seconds += it.seconds;
  return {{"shader", "shaders/aniso_environment_isotropic.glsl"},
          {"tables", files},
          {"scale", std::vector<float>(std::begin(it.scale), std::end(it.scale))},
          {"lookup",
           "each table a volume of one layer; anisoIsotropicEnvironment(N, V, k_d,iso, k_s,iso) "
           "with anisoEnvIsoScale = scale (at <N,V> = i / 32)"}};
}

}  // namespace

json write_environment(const std::string& dir, const Material& m, const Environment& env,
                       ExportSummary* sum) {
  if (const std::string why = environment_refusal(m); !why.empty())
    throw Error("export: --env " + env.name + ": " + why);
  json e = m.fiber()      ? write_fiber_environment(dir, m, env, sum)
           : m.maps.any() ? write_line_parts_environment(dir, m, env, sum)
                          : write_line_environment(dir, env, sum);
  if (m.isotropic_active()) e["isotropic"] = write_isotropic_environment(dir, m, env, sum);
  // A second fiber reads the same tables at T2, its lobe weighted 1 - weight.
  if (m.second_active())
    e["second_fiber"] = {{"angle_deg", m.second_angle_deg}, {"weight", m.second_weight}};
  return e;
}

std::string environment_refusal(const Material& m) {
  // The export's viewer lights what the preview's prefilters cover on its sample sphere, flat
  // sample and cylinder: not a torus's mathematical topology.
  const MathTopology mt = m.mathematical();
  const char* what = m.fiber() && mt != MathTopology::kNone && mt != MathTopology::kSphere
                         ? "a mathematical topology other than the sample sphere's"
                         : environment_unsupported(m);
  if (!what) return "";
  return "the export's viewer lights under an environment what aniso preview --env does, on the "
         "sample sphere, the flat sample and the cylinder; this material has " +
         std::string(what);
}

}  // namespace aniso
