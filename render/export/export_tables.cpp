// `aniso export`'s tables/ folder (render/export/export_tables.h).
#include "render/export/export_tables.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/ktx2.h"
#include "io/images/image_io.h"

namespace aniso {

using jsonu::json;

namespace {

KtxTexture ktx_of(const Image& img, KtxFormat f, const std::string& meaning) {
  KtxTexture t;
  t.format = f;
  t.width = img.width;
  t.height = img.height;
  const int c = ktx_channels(f);
  t.texels.resize(static_cast<size_t>(img.width) * img.height * c);
  for (size_t p = 0; p < static_cast<size_t>(img.width) * img.height; ++p)
    for (int k = 0; k < c; ++k)
      t.texels[p * c + k] = k < img.channels ? img.px[p * img.channels + k] : 1.f;  // alpha 1
  t.metadata["aniso.meaning"] = meaning;
  return t;
}

KtxTexture ktx_array(const std::vector<float>& v, int w, int h, int layers,
                     const std::string& meaning) {
  KtxTexture t;
  t.format = KtxFormat::kR32Float;
  t.width = w;
  t.height = h;
  t.layers = layers;
  t.texels = v;
  t.metadata["aniso.meaning"] = meaning;
  return t;
}

// A 2D array's layers side by side in one EXR (for engines that import no array textures):
// tables/STEM_atlas.exr, at most 8192 wide, roughly square; its layout for export.json.
json write_atlas(const std::string& dir, const std::string& stem, const std::vector<float>& v,
                 int w, int h, int layers, ExportSummary* sum) {
  int columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(layers) * h / w)));
  columns = std::clamp(columns, 1, std::max(1, std::min(layers, 8192 / std::max(w, 1))));
  const int rows = (layers + columns - 1) / columns;
  Image atlas(columns * w, rows * h, 1, 0.f);
  for (int k = 0; k < layers; ++k)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        atlas.at((k % columns) * w + x, (k / columns) * h + y, 0) =
            v[(static_cast<size_t>(k) * h + y) * w + x];
  const std::string file = "tables/" + stem + "_atlas.exr";
  write_exr(join_path(dir, file), atlas);
  sum->files.push_back(file);
  return {{"file", file},
          {"size", {atlas.width, atlas.height}},
          {"tile", {w, h}},
          {"columns", columns},
          {"rows", rows},
          {"layer_at",
           "layer k's texel (x, y) at (k mod columns) * tile_w + x, floor(k / columns) * "
           "tile_h + y; texels past the last layer 0. Sample within a tile (clamp to its texel "
           "centres), never across tiles"}};
}

}  // namespace

// The line tables (and the fiber factor tables) as KTX2 and EXR; the entries of export.json.
json write_tables(const std::string& dir, const Material& m, const ExportOptions& o,
                  ExportSummary* sum) {
  sum->line = bake_line(m, o.size, BakeIndex::kAngle);
  const BakeTables& t = sum->line;
  json tables = json::object();
  auto emit = [&](const std::string& stem, const Image& img, KtxFormat f, const char* meaning) {
    write_ktx2(join_path(dir, "tables/" + stem + ".ktx2"), ktx_of(img, f, meaning));
    write_exr(join_path(dir, "tables/" + stem + ".exr"), img);
    tables[stem] = {{"ktx2", "tables/" + stem + ".ktx2"},
                    {"exr", "tables/" + stem + ".exr"},
                    {"vk_format", ktx_format_name(f)},
                    {"size", {img.width, img.height}},
                    {"meaning", meaning}};
    sum->files.push_back("tables/" + stem + ".ktx2");
    sum->files.push_back("tables/" + stem + ".exr");
  };
  emit("diffuse", t.diffuse, KtxFormat::kR32Float, "D(a, b) of the line model (grey)");
  emit("specular", t.specular, KtxFormat::kR32Float, "S(a, b; n) of the line model (grey)");
  emit("combined", t.combined, KtxFormat::kRGBA16Float,
       "k_d D + k_s S in RGB, alpha 1 (colours baked in)");
  if (!m.fiber()) return tables;
  sum->fiber = true;
  sum->fiber_tables = bake_fiber(m, t, 64, 9, 16, 1, o.progress);
  const FiberBakeTables& fb = sum->fiber_tables;
  write_ktx2(join_path(dir, "tables/fiber_G.ktx2"),
             ktx_array(fb.G, fb.nphi, fb.nphi, fb.ns, "fiber factor G(phi_l, phi_v; s)"));
  write_ktx2(
      join_path(dir, "tables/fiber_F.ktx2"),
      ktx_array(fb.F, fb.nphi, fb.nphi, fb.ns * fb.nk, "fiber factor F(phi_l, phi_v; s, k)"));
  tables["fiber_G"] = {{"ktx2", "tables/fiber_G.ktx2"},
                       {"vk_format", "VK_FORMAT_R32_SFLOAT"},
                       {"size", {fb.nphi, fb.nphi}},
                       {"layers", fb.ns},
                       {"layer", "is: s = is / (ns - 1)"}};
  tables["fiber_F"] = {
      {"ktx2", "tables/fiber_F.ktx2"},
      {"vk_format", "VK_FORMAT_R32_SFLOAT"},
      {"size", {fb.nphi, fb.nphi}},
      {"layers", fb.ns * fb.nk},
      {"layer", "is * nk + k: s = is / (ns - 1), k = kappa / (1 + kappa) at k / (nk - 1)"}};
  sum->files.push_back("tables/fiber_G.ktx2");
  sum->files.push_back("tables/fiber_F.ktx2");
  tables["fiber_G"]["exr_atlas"] = write_atlas(dir, "fiber_G", fb.G, fb.nphi, fb.nphi, fb.ns, sum);
  tables["fiber_F"]["exr_atlas"] =
      write_atlas(dir, "fiber_F", fb.F, fb.nphi, fb.nphi, fb.ns * fb.nk, sum);
  return tables;
}

namespace {

// A fiber material's map of n: F's levels over its range (render/bake/bake.h: FiberStack) as
// tables/fiber_F_stack.ktx2, layers level * ns + is, the nk tables of phi side by side.
void write_fiber_stack(const std::string& dir, const Material& m, const ExportOptions& o,
                       const SpecularStack& st, ExportSummary* sum, json* tables) {
  const FiberBakeTables& fb = sum->fiber_tables;
  FiberStack fs =
      bake_fiber_stack(m, fb, bake_line(m, o.size, BakeIndex::kAngle), st, 0.2, 28, 1, o.progress);
  const std::vector<float> layers = fiber_stack_layers(fb, fs);
  write_ktx2(join_path(dir, "tables/fiber_F_stack.ktx2"),
             ktx_array(layers, fb.nk * fb.nphi, fb.nphi, fs.levels * fb.ns,
                       "fiber factor F(phi_l, phi_v; s, k) at levels of log n"));
  (*tables)["fiber_F_stack"] = {
      {"ktx2", "tables/fiber_F_stack.ktx2"},
      {"vk_format", "VK_FORMAT_R32_SFLOAT"},
      {"size", {fb.nk * fb.nphi, fb.nphi}},
      {"layers", fs.levels * fb.ns},
      {"layer", "level * ns + is: n = exp(log_n0 + level log_step), s = is / (ns - 1)"},
      {"x", "tile k (k = kappa / (1 + kappa) at k / (nk - 1)) holds x = (k + u) / nk of F's u"},
      {"levels", fs.levels},
      {"log_n0", fs.logn0},
      {"log_step", fs.log_step()},
      {"lookup",
       "f = clamp((log n - log_n0) / log_step, 0, levels - 1), l = min(floor f, levels - 2): F "
       "= F_l + (f - l) (F_l+1 - F_l), each level multi-linear in s and k as fiber_F"}};
  sum->files.push_back("tables/fiber_F_stack.ktx2");
  (*tables)["fiber_F_stack"]["exr_atlas"] =
      write_atlas(dir, "fiber_F_stack", layers, fb.nk * fb.nphi, fb.nphi, fs.levels * fb.ns, sum);
  ExportMapSet& set = sum->maps;
  set.f_levels = fs.levels;
  set.f_log_n0 = fs.logn0;
  set.f_log_step = fs.log_step() > 0 ? fs.log_step() : 1.0;
  fs.F.clear();
  fs.F.shrink_to_fit();
  sum->fiber_stack = std::move(fs);
}

}  // namespace

// The material's maps: each original file copied, and as KTX2 beside it: k_d, k_s and the fiber
// direction RGBA32F (a grey map's one channel in R, G and B; alpha 1), n and the topology's maps
// their first channel as R32F. With a line material's map of n, the stack of specular tables the
// shaders blend (tables/specular_stack.ktx2, a 2D array) and its entry in `tables`.
json write_maps(const std::string& dir, const Material& m, const ExportOptions& o,
                ExportSummary* sum, json* tables) {
  json maps = json::object();
  std::vector<std::string> names;
  // `img`: the map as the material loaded it (read from `rel` where it did not: topology maps).
  auto carry = [&](const std::string& rel, const char* key, const std::string& stem,
                   const Image* img, KtxFormat format, const char* meaning) {
    const std::string src = join_path(m.base_dir, rel);
    const std::string name = stem + std::filesystem::path(src).extension().string();
    for (const std::string& taken : names)
      if (taken == name || taken == stem + ".ktx2")
        throw Error("export: two of the material's maps would be written as tables/maps/" + name +
                    " (" + rel + "): rename one of them");
    names.insert(names.end(), {name, stem + ".ktx2"});
    const std::string bytes = read_text_file(src);
    write_text_file(join_path(dir, "tables/maps/" + name), bytes);
    const Image read = img ? Image{} : read_image(src).image;
    const Image& map = img ? *img : read;
    // R32F: the first channel; RGBA32F: a grey map's one channel in R, G and B, else its own
    // channels up to three (ktx_of fills the rest with 1).
    const int kept = format == KtxFormat::kR32Float ? 1
                     : map.channels == 1            ? 3
                                                    : std::min(map.channels, 3);
    Image v(map.width, map.height, kept);
    for (size_t p = 0; p < static_cast<size_t>(map.width) * map.height; ++p)
      for (int c = 0; c < kept; ++c)
        v.px[p * kept + c] = map.px[p * map.channels + (map.channels == 1 ? 0 : c)];
    const KtxTexture t = ktx_of(v, format, meaning);
    write_ktx2(join_path(dir, "tables/maps/" + stem + ".ktx2"), t);
    maps[key] = {{"original", "tables/maps/" + name},
                 {"ktx2", "tables/maps/" + stem + ".ktx2"},
                 {"vk_format", ktx_format_name(t.format)},
                 {"size", {t.width, t.height}},
                 {"meaning", meaning}};
    sum->files.push_back("tables/maps/" + name);
    sum->files.push_back("tables/maps/" + stem + ".ktx2");
  };
  auto stem_of = [](const std::string& rel) { return std::filesystem::path(rel).stem().string(); };
  constexpr KtxFormat kOne = KtxFormat::kR32Float, kRgba = KtxFormat::kRGBA32Float;
  // The topology's maps repeat over uv (docs/formats.md), whatever maps.wrap says of the others.
  ExportMapSet& set = sum->maps;
  if (const auto* r = m.topology_as<TopologyMapRef>()) {
    carry(r->file, "topology.map", stem_of(r->file), nullptr, kOne,
          "topology map h in [0, 1] over uv (m = 2h - 1, docs/models.md §4)");
    maps["topology.map"]["wrap"] = "repeat";
    set.topology_map = true;
    set.topology_amplitude = r->amplitude;
  }
  if (const auto* r = m.topology_as<SMapRef>()) {
    carry(r->file, "topology.s_map", stem_of(r->file), nullptr, kOne,
          "the topology s per texel over uv");
    maps["topology.s_map"]["wrap"] = "repeat";
    set.s_map = true;
  }
  const MaterialMaps& mp = m.maps;
  if (mp.kd) {
    carry(mp.kd_file, "kd", "kd", mp.kd.get(), kRgba,
          "k_d per texel over uv, linear RGB (alpha 1)");
    set.kd = true;
  }
  if (mp.ks) {
    carry(mp.ks_file, "ks", "ks", mp.ks.get(), kRgba,
          "k_s per texel over uv, linear RGB (alpha 1)");
    set.ks = true;
  }
  if (mp.fiber) {
    carry(mp.fiber_file, "fiber", "fiber", mp.fiber.get(), kRgba,
          "fiber direction per texel over uv: R, G = cos 2psi, sin 2psi (psi = atan2(G, R) / 2 "
          "from the reference tangent toward N x U)");
    set.fiber = true;
  }
  if (mp.n) {
    carry(mp.n_file, "n", "n", mp.n.get(), kOne, "the exponent n per texel over uv");
    {
      const SpecularStack st = bake_material_stack(m, o.size, BakeIndex::kAngle);
      const std::vector<float> levels = stack_levels(st);
      write_ktx2(join_path(dir, "tables/specular_stack.ktx2"),
                 ktx_array(levels, st.size, st.size, st.levels,
                           "S(a, b; n) of the line model at levels of log n"));
      (*tables)["specular_stack"] = {
          {"ktx2", "tables/specular_stack.ktx2"},
          {"vk_format", "VK_FORMAT_R32_SFLOAT"},
          {"size", {st.size, st.size}},
          {"layers", st.levels},
          {"layer", "k: n = exp(log_n0 + k log_step), indexed as specular"},
          {"log_n0", st.logn0},
          {"log_step", st.log_step()},
          {"lookup",
           "f = clamp((log n - log_n0) / log_step, 0, layers - 1), k = min(floor f, layers - 2): "
           "S = S_k + (f - k) (S_k+1 - S_k)"}};
      sum->files.push_back("tables/specular_stack.ktx2");
      (*tables)["specular_stack"]["exr_atlas"] =
          write_atlas(dir, "specular_stack", levels, st.size, st.size, st.levels, sum);
      set.n = true;
      set.levels = st.levels;
      set.log_n0 = st.logn0;
      set.log_step = st.log_step() > 0 ? st.log_step() : 1.0;  // one n: any step reads level 0
      sum->stack_max_abs_error = st.max_abs_error;
      if (m.fiber()) write_fiber_stack(dir, m, o, st, sum, tables);
    }
  }
  if (mp.amplitude) {
    carry(mp.amplitude_file, "amplitude", "amplitude", mp.amplitude.get(), kOne,
          "the topology map's amplitude A per texel over uv (fiber model, docs/models.md §4)");
    // Drawn over a topology map (models/topology.h: s_at); a material without one ignores it.
    set.amplitude = set.topology_map;
    if (!set.topology_map)
      sum->warnings.push_back("the map of the topology's amplitude (" + mp.amplitude_file +
                              ") is carried in tables/maps/ but the material has no topology map "
                              "for it to scale: nothing draws it");
  }
  if (set.any() || mp.amplitude) maps["wrap"] = mp.repeat ? "repeat" : "clamp";
  return maps;
}

}  // namespace aniso
