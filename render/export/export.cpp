#include "render/export/export.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "core/angles.h"
#include "core/color.h"
#include "core/error.h"
#include "core/progress.h"
#include "geometry/mesh.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/ktx2.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "render/export/export_engines.h"
#include "render/export/export_environment.h"
#include "render/export/export_tables.h"
#include "render/shaders_embedded.h"

namespace aniso {

using jsonu::json;

namespace {

// The sample object: a sphere with unit normals and tangents (xyz unit and orthogonal to the
// normal, w = +1: bitangent = normal x tangent), uv and indices, packed for one .bin.
struct SphereBuffers {
  std::vector<uint8_t> bin;
  size_t vertices = 0, indices = 0;
  size_t off_p = 0, off_n = 0, off_t = 0, off_uv = 0, off_i = 0;
  float pmin[3] = {1e30f, 1e30f, 1e30f}, pmax[3] = {-1e30f, -1e30f, -1e30f};
};

SphereBuffers sphere_buffers() {
  const TriMesh mesh = make_shape("sphere");
  SphereBuffers b;
  b.vertices = mesh.P.size();
  b.indices = mesh.tri.size() * 3;
  std::vector<float> p, n, t, uv;
  for (size_t i = 0; i < mesh.P.size(); ++i) {
    const Vec3 N = normalize(mesh.N[i]);
    Vec3 T = mesh.U[i] - N * dot(N, mesh.U[i]);
    if (length(T) < 1e-9) T = cross(std::abs(N.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0), N);
    T = normalize(T);
    const Vec3& P = mesh.P[i];
    const float pf[3] = {float(P.x), float(P.y), float(P.z)};
    for (int k = 0; k < 3; ++k) {
      p.push_back(pf[k]);
      b.pmin[k] = std::min(b.pmin[k], pf[k]);
      b.pmax[k] = std::max(b.pmax[k], pf[k]);
    }
    n.insert(n.end(), {float(N.x), float(N.y), float(N.z)});
    t.insert(t.end(), {float(T.x), float(T.y), float(T.z), 1.f});
    uv.insert(uv.end(), {mesh.uv[i][0], mesh.uv[i][1]});
  }
  auto append = [&](const void* data, size_t bytes) {
    const size_t at = b.bin.size();
    b.bin.resize(at + bytes);
    std::memcpy(b.bin.data() + at, data, bytes);
    while (b.bin.size() % 4) b.bin.push_back(0);
    return at;
  };
  b.off_p = append(p.data(), p.size() * 4);
  b.off_n = append(n.data(), n.size() * 4);
  b.off_t = append(t.data(), t.size() * 4);
  b.off_uv = append(uv.data(), uv.size() * 4);
  // glTF's front faces are counter-clockwise seen from outside: each triangle is ordered so its
  // geometric normal agrees with the vertex normals.
  std::vector<uint32_t> idx;
  for (const auto& tri : mesh.tri) {
    const Vec3 g = cross(mesh.P[tri[1]] - mesh.P[tri[0]], mesh.P[tri[2]] - mesh.P[tri[0]]);
    const bool ccw = dot(g, mesh.N[tri[0]] + mesh.N[tri[1]] + mesh.N[tri[2]]) >= 0;
    idx.insert(idx.end(), {tri[0], ccw ? tri[1] : tri[2], ccw ? tri[2] : tri[1]});
  }
  b.off_i = append(idx.data(), idx.size() * 4);
  return b;
}

// A material with a fiber map: KHR_materials_anisotropy's anisotropyTexture, RG the direction in
// the (tangent, bitangent) plane encoded to [0, 1] (across the fibers: psi + 90 deg, as the
// rotation of the uniform case), B the strength (1: the factor applies; with `strength`, each
// texel's own, the factor then 1). The rotation is then 0.
// The anisotropy direction is a line (d and -d shade alike), but an engine filters the texture's
// vectors: neighbours of opposite sign average toward zero. The signs are chosen along a maximum
// spanning tree of the texel grid, an edge weighing how parallel its two lines are: every tree
// edge agrees, and the disagreements left are where the lines themselves turn fast (beside a
// point they turn round by half a turn, where no choice of signs is continuous).
Image anisotropy_texture(const Material& m, const GltfPbrTexels* strength) {
  const Image& f = *m.maps.fiber;
  const int w = strength ? strength->w : f.width, h = strength ? strength->h : f.height;
  const size_t n = static_cast<size_t>(w) * h;
  std::vector<double> dx(n), dy(n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t t = static_cast<size_t>(y) * w + x;
      const double dir = strength ? strength->rotation_rad[t]
                                  : 0.5 * std::atan2(f.at(x, y, 1), f.at(x, y, 0)) + M_PI / 2;
      dx[t] = std::cos(dir), dy[t] = std::sin(dir);
    }
  auto dot = [&](size_t a, size_t b) { return dx[a] * dx[b] + dy[a] * dy[b]; };
  struct Edge {
    uint32_t a, b;
    float weight;
  };
  std::vector<Edge> edges;
  edges.reserve(2 * n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto t = static_cast<uint32_t>(static_cast<size_t>(y) * w + x);
      if (x + 1 < w) edges.push_back({t, t + 1, static_cast<float>(std::abs(dot(t, t + 1)))});
      if (y + 1 < h)
        edges.push_back({t, t + static_cast<uint32_t>(w),
                         static_cast<float>(std::abs(dot(t, t + static_cast<size_t>(w))))});
    }
  std::stable_sort(edges.begin(), edges.end(),
                   [](const Edge& p, const Edge& q) { return p.weight > q.weight; });
  std::vector<uint32_t> parent(n);
  for (size_t t = 0; t < n; ++t) parent[t] = static_cast<uint32_t>(t);
  auto root = [&](uint32_t t) {
    while (parent[t] != t) t = parent[t] = parent[parent[t]];
    return t;
  };
  std::vector<std::vector<uint32_t>> tree(n);
  for (const Edge& e : edges) {
    const uint32_t ra = root(e.a), rb = root(e.b);
    if (ra == rb) continue;
    parent[ra] = rb;
    tree[e.a].push_back(e.b);
    tree[e.b].push_back(e.a);
  }
  std::vector<int8_t> sign(n, 0);
  std::vector<uint32_t> queue;
  for (size_t s = 0; s < n; ++s) {
    if (sign[s]) continue;
    sign[s] = 1;
    queue.assign(1, static_cast<uint32_t>(s));
    for (size_t q = 0; q < queue.size(); ++q) {
      const uint32_t t = queue[q];
      for (const uint32_t u : tree[t])
        if (!sign[u]) {
          sign[u] = static_cast<int8_t>(dot(t, u) < 0 ? -sign[t] : sign[t]);
          queue.push_back(u);
        }
    }
  }
  Image out(w, h, 3);
  for (size_t t = 0; t < n; ++t) {
    out.px[3 * t] = static_cast<float>(0.5 + 0.5 * sign[t] * dx[t]);
    out.px[3 * t + 1] = static_cast<float>(0.5 + 0.5 * sign[t] * dy[t]);
    out.px[3 * t + 2] = strength ? strength->strength[t] : 1.f;
  }
  return out;
}

// The glTF's textures (file names in gltf/, empty where absent): the anisotropy direction (and
// strength), and per texel the base colour (sRGB) and metallic-roughness (G roughness, B metallic).
struct GltfTextures {
  std::string anisotropy, base_color, metallic_roughness;
  // KHR_materials_specular per texel: the specular colour (sRGB, scaled by the factor), or "".
  std::string specular_color;
  RGB specular_factor{1, 1, 1};
  bool per_texel = false;  // the three from fit_gltf_pbr_texels: the factors are then 1
};

json gltf_document(const Material& m, const GltfPbr& pbr, const SphereBuffers& b,
                   const json& tables, const GltfTextures& tex) {
  constexpr int kFloat = 5126, kUint = 5125, kArray = 34962, kElements = 34963;
  const size_t nv = b.vertices;
  json views = json::array(), accessors = json::array();
  auto add = [&](size_t offset, size_t bytes, int target, int type, size_t count,
                 const char* shape) {
    views.push_back(
        {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}, {"target", target}});
    accessors.push_back({{"bufferView", views.size() - 1},
                         {"componentType", type},
                         {"count", count},
                         {"type", shape}});
    return accessors.size() - 1;
  };
  const size_t ap = add(b.off_p, nv * 12, kArray, kFloat, nv, "VEC3");
  accessors[ap]["min"] = {b.pmin[0], b.pmin[1], b.pmin[2]};
  accessors[ap]["max"] = {b.pmax[0], b.pmax[1], b.pmax[2]};
  const size_t an = add(b.off_n, nv * 12, kArray, kFloat, nv, "VEC3");
  const size_t at = add(b.off_t, nv * 16, kArray, kFloat, nv, "VEC4");
  const size_t auv = add(b.off_uv, nv * 8, kArray, kFloat, nv, "VEC2");
  const size_t ai = add(b.off_i, b.indices * 4, kElements, kUint, b.indices, "SCALAR");
  json material_json;
  material_to_json(m, &material_json);
  json mat = {
      {"name", "aniso"},
      {"pbrMetallicRoughness",
       {{"baseColorFactor", {pbr.base_color[0], pbr.base_color[1], pbr.base_color[2], 1.0}},
        {"metallicFactor", pbr.metallic},
        {"roughnessFactor", pbr.roughness}}},
      {"extensions",
       {{"KHR_materials_anisotropy",
         {{"anisotropyStrength", pbr.strength}, {"anisotropyRotation", pbr.rotation_rad}}}}},
      {"extras",
       {{"aniso",
         {{"model", model_name(m.model)},
          {"material", material_json},
          {"tables", tables},
          {"fit",
           {{"lobe_relative_rms", pbr.lobe_rel_rms},
            {"whole_model_relative_rms", pbr.total_rel_rms},
            {"mapping", pbr.mapping}}}}}}}};
  json doc_extra = json::object();
  json images = json::array(), textures = json::array();
  auto texture = [&](const std::string& uri) {
    images.push_back({{"uri", uri}});
    textures.push_back({{"sampler", 0}, {"source", images.size() - 1}});
    return textures.size() - 1;
  };
  auto& ext = mat["extensions"]["KHR_materials_anisotropy"];
  auto& pmr = mat["pbrMetallicRoughness"];
  if (!tex.anisotropy.empty()) {
    ext["anisotropyRotation"] = 0.0;
    ext["anisotropyTexture"] = {{"index", texture(tex.anisotropy)}};
    if (tex.per_texel) ext["anisotropyStrength"] = 1.0;
  }
  if (!tex.base_color.empty()) {
    pmr["baseColorTexture"] = {{"index", texture(tex.base_color)}};
    pmr["baseColorFactor"] = {1.0, 1.0, 1.0, 1.0};
  }
  if (!tex.metallic_roughness.empty()) {
    pmr["metallicRoughnessTexture"] = {{"index", texture(tex.metallic_roughness)}};
    pmr["metallicFactor"] = 1.0;
    pmr["roughnessFactor"] = 1.0;
  }
  // KHR_materials_specular: F0 = min(0.04 specularColor, 1) specularFactor for a dielectric.
  const bool specular = tex.per_texel ? !tex.specular_color.empty() : pbr.specular;
  if (specular) {
    json sp = {{"specularFactor", 1.0}};
    const RGB& f = tex.per_texel ? tex.specular_factor : pbr.specular_color;
    sp["specularColorFactor"] = {f[0], f[1], f[2]};
    if (tex.per_texel) sp["specularColorTexture"] = {{"index", texture(tex.specular_color)}};
    mat["extensions"]["KHR_materials_specular"] = sp;
  }
  if (!images.empty()) {
    doc_extra["images"] = images;
    // Linear filtering, clamped at the border (docs/formats.md's default wrap for material maps).
    doc_extra["samplers"] = {
        {{"magFilter", 9729}, {"minFilter", 9729}, {"wrapS", 33071}, {"wrapT", 33071}}};
    doc_extra["textures"] = textures;
  }
  json doc = {
      {"asset", {{"version", "2.0"}, {"generator", "aniso export"}}},
      {"extensionsUsed", specular ? json{"KHR_materials_anisotropy", "KHR_materials_specular"}
                                  : json{"KHR_materials_anisotropy"}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "aniso sample"}}}},
      {"meshes",
       {{{"name", "sphere"},
         {"primitives",
          {{{"attributes",
             {{"POSITION", ap}, {"NORMAL", an}, {"TANGENT", at}, {"TEXCOORD_0", auv}}},
            {"indices", ai},
            {"material", 0}}}}}}},
      {"materials", {mat}},
      {"buffers", {{{"uri", "sample.bin"}, {"byteLength", b.bin.size()}}}},
      {"bufferViews", views},
      {"accessors", accessors}};
  doc.update(doc_extra);
  return doc;
}

// Where three.js is: ANISO_THREE_DIR (environment); else an installed aniso's own copy,
// BIN/../share/aniso/three beside the running binary; else where scripts/install_deps.sh put it
// for a build.
std::string three_dir() {
  namespace fs = std::filesystem;
  const char* env = std::getenv("ANISO_THREE_DIR");
  if (env && *env) return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "aniso" / "three";
    if (fs::is_regular_file(installed / "three.module.js", ec)) return installed.string();
  }
  return ANISO_THREE_DIR;
}

// The three.js viewer: the page, its module, and three itself (copied so the folder works
// offline) from three_dir().
json write_viewer(const std::string& dir, ExportSummary* sum) {
  namespace fs = std::filesystem;
  write_text_file(join_path(dir, "three/viewer.html"), shaders::viewer_html);
  write_text_file(join_path(dir, "three/aniso_viewer.js"), shaders::aniso_viewer_js);
  sum->files.push_back("three/viewer.html");
  sum->files.push_back("three/aniso_viewer.js");
  const std::string three = three_dir();
  json j = {{"page", "three/viewer.html"},
            {"query",
             "?shape=sphere&view=x,y,z&light=x,y,z&size=WxH[&fill=E&background=g] "
             "renders the frame of `aniso preview` with the same options; no query: "
             "an orbit viewer (drag; shift+drag moves the light)"},
            {"serve",
             "over http (module scripts do not load from file://), e.g. `python3 -m "
             "http.server` in the export folder, then open /three/viewer.html"}};
  bool copied = true;
  for (const char* f : {"three.module.js", "three.core.js"}) {
    const std::string src = join_path(three, f);
    std::error_code ec;
    if (!fs::is_regular_file(src, ec)) {
      copied = false;
      continue;
    }
    write_text_file(join_path(dir, std::string("three/") + f), read_text_file(src));
    sum->files.push_back(std::string("three/") + f);
  }
  if (!copied) {
    const std::string w = "three.js not found in " + three +
                          " (set ANISO_THREE_DIR to three's build/ folder, or copy "
                          "three.module.js and three.core.js into three/ yourself)";
    sum->warnings.push_back(w);
    j["three"] = w;
  } else {
    j["three"] = "three/three.module.js and three.core.js, copied from " + three;
  }
  return j;
}

}  // namespace

ExportShaders export_shaders(int texels, const FiberBakeTables* fiber, const ExportMapSet* maps) {
  char def[64];
  std::snprintf(def, sizeof def, "#define ANISO_TEXELS %d.0\n", texels);
  ExportShaders s;
  s.glsl_lookup = std::string(def) + shaders::aniso_lookup_glsl;
  s.glsl_fragment = "#version 330 core\n" + s.glsl_lookup + "\n" + shaders::aniso_main_frag;
  s.hlsl_lookup = std::string(def) + shaders::aniso_lookup_hlsli;
  s.hlsl_pixel = s.hlsl_lookup + "\n" + shaders::aniso_main_hlsl;
  // The fiber model's sizes: its function files, and before the maps' in their complete shaders.
  std::string fdef;
  if (fiber) {
    char b[128];
    std::snprintf(b, sizeof b, "#define ANISO_NPHI %d\n#define ANISO_NS %d\n#define ANISO_NK %d\n",
                  fiber->nphi, fiber->ns, fiber->nk);
    fdef = b;
    s.glsl_fiber = fdef + shaders::aniso_fiber_glsl;
    s.hlsl_fiber = fdef + shaders::aniso_fiber_hlsli;
  }
  if (maps && maps->any()) {
    std::string mdef;
    for (const auto& [on, name] : {std::pair{maps->kd, "ANISO_KD_MAP"},
                                   {maps->ks, "ANISO_KS_MAP"},
                                   {maps->fiber, "ANISO_FIBER_MAP"},
                                   {maps->n, "ANISO_N_MAP"},
                                   {maps->s_map, "ANISO_S_MAP"},
                                   {maps->topology_map, "ANISO_TOPOLOGY_MAP"},
                                   {maps->amplitude, "ANISO_AMPLITUDE_MAP"}})
      if (on) mdef += std::string("#define ") + name + "\n";
    if (maps->topology_map && !maps->amplitude)
      mdef += "#define ANISO_TOPOLOGY_AMPLITUDE " + shader_float(maps->topology_amplitude) + "\n";
    if (maps->n) {
      mdef += "#define ANISO_STACK_LEVELS " + std::to_string(maps->levels) +
              "\n#define ANISO_LOG_N0 " + shader_float(maps->log_n0) + "\n#define ANISO_LOG_STEP " +
              shader_float(maps->log_step) + "\n";
      if (maps->f_levels > 0)
        mdef += "#define ANISO_FIBER_F_LEVELS " + std::to_string(maps->f_levels) +
                "\n#define ANISO_FIBER_LOG_N0 " + shader_float(maps->f_log_n0) +
                "\n#define ANISO_FIBER_LOG_STEP " + shader_float(maps->f_log_step) + "\n";
    }
    // A fiber material's complete maps shader draws the fiber model (anisoFiberRadianceMapped).
    s.glsl_maps = mdef + shaders::aniso_maps_glsl;
    s.glsl_maps_fragment = "#version 330 core\n" + s.glsl_lookup + "\n" + s.glsl_fiber + "\n" +
                           s.glsl_maps + "\n" + shaders::aniso_maps_main_frag;
    s.hlsl_maps = mdef + shaders::aniso_maps_hlsli;
    s.hlsl_maps_pixel = s.hlsl_lookup + "\n" + s.hlsl_fiber + "\n" + s.hlsl_maps + "\n" +
                        shaders::aniso_maps_main_hlsl;
  }
  if (!fiber) return s;
  s.glsl_fiber_fragment = "#version 330 core\n" + s.glsl_lookup + "\n" + s.glsl_fiber + "\n" +
                          shaders::aniso_fiber_main_frag;
  s.hlsl_fiber_pixel = s.hlsl_lookup + "\n" + s.hlsl_fiber + "\n" + shaders::aniso_fiber_main_hlsl;
  return s;
}

namespace {

json conventions(const ExportSummary& s) {
  json c = {
      {"values",
       "linear radiance factors, not sRGB; KTX2 and EXR hold the same numbers (the "
       "combined table as half float in KTX2)"},
      {"line_tables",
       "x (s) = a = <L,T>, y (t) = b = <V,T>; texel i at the angle acos(-c) = pi i / (N - 1), so "
       "coordinate = (acos(-c) / pi (N - 1) + 0.5) / N; texel centres on c = -1 and c = 1"},
      {"row_order",
       "the first stored row is t = 0 (KTXorientation rd): b = -1; upload as is in "
       "OpenGL/WebGL/Vulkan/D3D (no flip; Unity's importer flips PNG, not KTX2)"},
      {"filtering", "bilinear, clamp to edge, no mipmaps"},
      {"tangent",
       "T is the mesh tangent (glTF TANGENT, bitangent = normal x tangent * w) turned "
       "by the fiber angle psi about the normal toward the bitangent"},
      {"shading", "radiance = E (k_d D + k_s S) <N,L>^+ per light; <N,L> is not baked"},
      {"not_baked",
       s.fiber ? "the isotropic and second-fiber terms (fiber model has none); the fiber factor "
                 "tables multiply D and S (see tables.fiber_*)"
               : "the isotropic term and the second fiber (evaluate them in the shader if the "
                 "material has them)"}};
  if (s.maps.any())
    c["maps"] =
        "tables/maps/*.ktx2 over glTF texture coordinates (TEXCOORD_0; the first stored row at "
        "v = 0, no flip), texel centres at (i + 1/2) / W, linear, no mipmaps, wrap as maps.wrap; "
        "with a map of the fiber direction the tangent passed in is the mesh tangent (not turned "
        "by fiber_angle_deg) and the map's psi turns it about the normal; the topology's maps "
        "(topology.map, topology.s_map) repeat";
  return c;
}

json measured_errors(const ExportSummary& s) {
  json e = {{"line_tables",
             {{"against", "direct evaluation of k_d D + k_s S (bilinear lookup)"},
              {"max_abs", s.line.max_abs_error},
              {"rms", s.line.rms_error},
              {"peak_value", s.line.peak_value},
              {"samples", s.line.samples},
              {"seed", s.line.seed}}},
            {"gltf",
             {{"lobe_relative_rms", s.pbr.lobe_rel_rms},
              {"whole_model_relative_rms", s.pbr.total_rel_rms},
              {"other_mapping_relative_rms", s.pbr.other_rel_rms},
              {"direction_pairs", s.pbr.samples},
              {"mapping", s.pbr.mapping}}}};
  if (s.maps.n)
    e["specular_stack"] = {
        {"against", "S at random (a, b) and n in the map's range, and the ridge"},
        {"max_abs", s.stack_max_abs_error}};
  if (s.fiber_stack.levels > 0)
    e["fiber_F_stack"] = {
        {"against", "the full fiber model, random L, V, s and n in the map's range"},
        {"max_abs", s.fiber_stack.max_abs_error},
        {"rms", s.fiber_stack.rms_error},
        {"samples", s.fiber_stack.samples}};
  if (s.fiber)
    e["fiber_tables"] = {{"against", "the full fiber model, random L, V, s"},
                         {"max_abs", s.fiber_tables.max_abs_error},
                         {"p99", s.fiber_tables.p99_error},
                         {"rms", s.fiber_tables.rms_error},
                         {"samples", s.fiber_tables.samples}};
  return e;
}

// An export goes only where nothing but an earlier export is (io/files/files.h).
void check_export_folder(const std::string& dir) { check_output_folder(dir, OutputKind::kExport); }

}  // namespace

// gltf/: the sample sphere, its material and (with a fiber map) the anisotropy texture.
void write_gltf(const std::string& tmp, const Material& m, const json& tables, ExportSummary* sum) {
  const SphereBuffers sphere = sphere_buffers();
  json gtables = json::object();
  for (const auto& [k, v] : tables.items())
    if (v.contains("ktx2") && v["ktx2"].is_string())  // (the environment's terms are seven)
      gtables[k] = "../" + v["ktx2"].get<std::string>();
  GltfTextures tex;
  auto png = [&](const std::string& name, const Image& img) {
    write_png(join_path(tmp, "gltf/" + name), img, 8);  // PNG: what glTF core takes
    sum->files.push_back("gltf/" + name);
    return name;
  };
  const MaterialMaps& mp = m.maps;
  if ((mp.kd || mp.ks || mp.n) && !m.fiber() && !m.isotropic_active() && !m.second_active()) {
    // Per texel, on the finest of the maps' grids: base colour, metallic, roughness and the
    // anisotropy's direction and strength, each as fit_gltf_pbr gives them at the texel.
    int w = 0, h = 0;
    for (const auto* img : {mp.kd.get(), mp.ks.get(), mp.n.get(), mp.fiber.get()})
      if (img) w = std::max(w, img->width), h = std::max(h, img->height);
    const GltfPbrTexels px = fit_gltf_pbr_texels(m, w, h);
    Image base(w, h, 3), mr(w, h, 3);
    for (size_t t = 0; t < px.metallic.size(); ++t) {
      for (int c = 0; c < 3; ++c)
        base.px[3 * t + c] = static_cast<float>(srgb_encode(px.base_color[3 * t + c]));
      mr.px[3 * t] = 1.f;  // R: unused by metallic-roughness (occlusion's channel)
      mr.px[3 * t + 1] = px.roughness[t];
      mr.px[3 * t + 2] = px.metallic[t];
    }
    tex.per_texel = true;
    if (px.specular) {
      // specularColorFactor the largest colour, the texture each texel's share of it (sRGB).
      double top = 1e-6;
      for (float v : px.specular_color) top = std::max(top, static_cast<double>(v));
      tex.specular_factor = {top, top, top};
      Image sc(w, h, 3);
      for (size_t i = 0; i < sc.px.size(); ++i)
        sc.px[i] = static_cast<float>(srgb_encode(px.specular_color[i] / top));
      tex.specular_color = png("sample_specular_color.png", sc);
    }
    tex.base_color = png("sample_base_color.png", base);
    tex.metallic_roughness = png("sample_metallic_roughness.png", mr);
    if (mp.fiber) tex.anisotropy = png("sample_anisotropy.png", anisotropy_texture(m, &px));
    sum->gltf_texels = {w, h, px.n_nodes, px.worst_total_rel_rms, px.mapping, px.specular};
  } else if (mp.fiber) {
    tex.anisotropy = png("sample_anisotropy.png", anisotropy_texture(m, nullptr));
  }
  const json doc = gltf_document(m, sum->pbr, sphere, gtables, tex);
  write_text_file(join_path(tmp, "gltf/sample.gltf"), doc.dump(2) + "\n");
  write_text_file(join_path(tmp, "gltf/sample.bin"),
                  std::string(sphere.bin.begin(), sphere.bin.end()));
  sum->files.push_back("gltf/sample.gltf");
  sum->files.push_back("gltf/sample.bin");
}

ExportSummary export_material(const Material& m, const std::string& dir, const ExportOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (o.size < 2 || o.size > 8192) throw Error("export: --size must be between 2 and 8192");
  check_export_folder(dir);
  ExportSummary sum;
  sum.pbr = fit_gltf_pbr(m);
  write_folder_atomically(dir, OutputKind::kExport, [&](const std::string& tmp) {
    // A maps material takes seconds (the specular stack, a lobe fit per glTF texel).
    Progress bar("export: tables, maps, shaders, glTF, viewer", 5, o.progress);
    json tables = write_tables(tmp, m, o, &sum);
    if (o.environment) {
      sum.environment_left_out =
          o.environment_where_it_applies ? environment_refusal(m) : std::string();
      if (sum.environment_left_out.empty())
        tables["environment"] = write_environment(tmp, m, *o.environment, &sum);
      else
        tables["environment_left_out"] = o.environment->name + ": " + sum.environment_left_out;
    }
    bar.advance();
    const json maps = write_maps(tmp, m, o, &sum, &tables);
    bar.advance();
    const ExportShaders sh =
        export_shaders(o.size, sum.fiber ? &sum.fiber_tables : nullptr, &sum.maps);
    std::vector<std::pair<std::string, std::string>> files = {
        {"shaders/aniso_lookup.glsl", sh.glsl_lookup},
        {"shaders/aniso.frag", sh.glsl_fragment},
        {"shaders/aniso_lookup.hlsli", sh.hlsl_lookup},
        {"shaders/aniso_ps.hlsl", sh.hlsl_pixel}};
    if (sum.fiber)
      files.insert(files.end(), {{"shaders/aniso_fiber.glsl", sh.glsl_fiber},
                                 {"shaders/aniso_fiber.frag", sh.glsl_fiber_fragment},
                                 {"shaders/aniso_fiber.hlsli", sh.hlsl_fiber},
                                 {"shaders/aniso_fiber_ps.hlsl", sh.hlsl_fiber_pixel}});
    if (sum.maps.any())
      files.insert(files.end(), {{"shaders/aniso_maps.glsl", sh.glsl_maps},
                                 {"shaders/aniso_maps.frag", sh.glsl_maps_fragment},
                                 {"shaders/aniso_maps.hlsli", sh.hlsl_maps},
                                 {"shaders/aniso_maps_ps.hlsl", sh.hlsl_maps_pixel}});
    json engines;
    for (auto& f : engine_packages(m, o.size, &engines)) files.push_back(std::move(f));
    for (const auto& [name, text] : files) {
      std::filesystem::create_directories(join_path(tmp, parent_dir(name)));
      write_text_file(join_path(tmp, name), text);
      sum.files.push_back(name);
    }
    bar.advance();
    write_gltf(tmp, m, tables, &sum);
    bar.advance();
    const json viewer = write_viewer(tmp, &sum);
    bar.advance();
    bar.finish();
    json material;
    material_to_json(m, &material);
    sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    json j = {
        {"format", "aniso-export"},
        {"version", 1},
        {"command", o.command},
        {"model", model_name(m.model)},
        {"material", material},
        {"tables", tables},
        {"maps", maps},
        {"shaders",
         {{"glsl", {"shaders/aniso_lookup.glsl", "shaders/aniso.frag"}},
          {"hlsl", {"shaders/aniso_lookup.hlsli", "shaders/aniso_ps.hlsl"}},
          {"fiber", sum.fiber ? json{"shaders/aniso_fiber.glsl", "shaders/aniso_fiber.frag",
                                     "shaders/aniso_fiber.hlsli", "shaders/aniso_fiber_ps.hlsl"}
                              : json(nullptr)},
          {"maps", sum.maps.any() ? json{"shaders/aniso_maps.glsl", "shaders/aniso_maps.frag",
                                         "shaders/aniso_maps.hlsli", "shaders/aniso_maps_ps.hlsl"}
                                  : json(nullptr)},
          {"checked_by",
           "glslangValidator (GLSL 330 and HLSL via -D), SPIR-V to MSL "
           "by spirv-cross, in the tests"},
          {"covers", std::string(sum.fiber ? "the line-model lookup and the fiber model's factor "
                                             "tables (anisoFiberRadiance: one topology s per call)"
                                           : "the line-model lookup") +
                         (sum.maps.any() ? "; the material's maps of k_d, k_s, the fiber direction "
                                           "and n per fragment (aniso_maps: anisoMapsAt, "
                                           "anisoRadianceMapped; the fiber model's "
                                           "anisoFiberRadianceMapped after aniso_fiber, with a "
                                           "map of n F from tables/fiber_F_stack.ktx2, and the "
                                           "topology's map of s, or topology map and amplitude "
                                           "over s_math, by anisoTopologyAt)"
                                         : "")}}},
        {"gltf",
         {{"file", "gltf/sample.gltf"},
          {"extension", (sum.gltf_texels.w > 0 ? sum.gltf_texels.specular : sum.pbr.specular)
                            ? json{"KHR_materials_anisotropy", "KHR_materials_specular"}
                            : json("KHR_materials_anisotropy")},
          {"mapping", sum.pbr.mapping},
          {"roughness", sum.pbr.roughness},
          {"anisotropy_strength", sum.pbr.strength},
          {"anisotropy_rotation_rad", sum.pbr.rotation_rad},
          {"direction",
           "anisotropy direction = psi + 90 deg (roughness grows "
           "across the fibers)"},
          {"per_texel",
           sum.gltf_texels.w > 0
               ? json{{"texels", {sum.gltf_texels.w, sum.gltf_texels.h}},
                      {"lobe_fits", sum.gltf_texels.nodes},
                      {"worst_whole_model_relative_rms", sum.gltf_texels.worst_rel_rms},
                      {"mapping", sum.gltf_texels.mapping},
                      {"textures",
                       std::string("baseColorTexture (sRGB), metallicRoughnessTexture (G "
                                   "roughness, B metallic), anisotropyTexture (RG direction, B "
                                   "strength); factors 1") +
                           (sum.gltf_texels.specular
                                ? "; KHR_materials_specular's specularColorTexture (sRGB) times "
                                  "specularColorFactor (F0 / 0.04 of the brightest texel)"
                                : "")}}
               : json(nullptr)}}},
        {"engines", engines},
        {"three", viewer},
        {"warnings", sum.warnings},
        {"conventions", conventions(sum)},
        {"errors", measured_errors(sum)},
        {"files", sum.files},
        {"seconds", sum.seconds}};
    if (o.measure_engines) j["engines_measured"] = o.measure_engines(tmp);
    write_text_file(join_path(tmp, "export.json"), j.dump(2) + "\n");
  });
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace aniso
