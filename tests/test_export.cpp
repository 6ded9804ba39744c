// `aniso export`: KTX2 read back by an independent reader (npm ktx-parse), shaders
// compiled by Khronos' glslangValidator and translated by spirv-cross, the glTF checked by the
// Khronos glTF-Validator, and the folder rules.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/angles.h"
#include "core/color.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/ktx2.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "models/material_maps.h"
#include "render/bake/bake.h"
#include "render/export/export.h"
#include "test_util.h"

namespace aniso {
namespace {

using test::run_command;
using test::tmp_dir;

std::string web_dir() { return std::string(ANISO_SOURCE_DIR) + "/web"; }

// Runs a node script of web/ (its packages installed by scripts/install_deps.sh) and parses the
// JSON it prints.
nlohmann::json node_json(const std::string& script, const std::string& args, int* status) {
  const auto r = run_command("cd '" + web_dir() + "' && node " + script + " " + args);
  *status = r.status;
  const auto j = nlohmann::json::parse(r.output, nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << r.output;
  return j;
}

// A complete exported shader compiled by Khronos' reference compiler (GLSL 330 to SPIR-V for
// OpenGL, HLSL through its -D front end to SPIR-V for Vulkan) and translated to Metal by
// spirv-cross; the output holds the Metal source.
test::RunResult compile_to_metal(const std::string& path) {
  const std::string spv = path + ".spv";
  const bool hlsl = lower_ext(path) == ".hlsl";
  return run_command(
      (hlsl ? "glslangValidator -D -V -S frag -e main -o '"
            : "glslangValidator '" + path + "' && glslangValidator -G --aml --amb -o '") +
      spv + "' '" + path + "' && spirv-cross '" + spv + "' --msl");
}

// An export's complete maps shaders (GLSL and HLSL) compile to Metal and use each of `names`.
void expect_complete_maps_shaders(const std::string& export_dir,
                                  std::initializer_list<const char*> names) {
  for (const char* f : {"aniso_maps.frag", "aniso_maps_ps.hlsl"}) {
    const test::RunResult r = compile_to_metal(export_dir + "/shaders/" + f);
    EXPECT_EQ(r.status, 0) << f << ": " << r.output;
    for (const char* name : names)
      EXPECT_NE(r.output.find(name), std::string::npos) << f << " " << name << ": " << r.output;
  }
}

Material brushed() {
  Material m;
  m.kd = {0.20, 0.15, 0.10};
  m.ks = {0.60, 0.60, 0.60};
  m.n = 60;
  m.fiber_angle_deg = 30;
  return m;
}

TEST(KTX2, HalfFloatRoundsToNearestEven) {
  EXPECT_EQ(float_to_half(1.0f), 0x3C00);
  EXPECT_EQ(float_to_half(-2.0f), 0xC000);
  EXPECT_EQ(float_to_half(65504.0f), 0x7BFF);
  EXPECT_EQ(float_to_half(std::ldexp(1.0f, -24)), 0x0001);         // smallest subnormal
  EXPECT_EQ(float_to_half(std::ldexp(1.0f, -25)), 0x0000);         // a tie: to even (zero)
  EXPECT_EQ(float_to_half(std::ldexp(3.0f, -25)), 0x0002);         // 1.5 ulp: to even (2)
  EXPECT_EQ(float_to_half(1.0f + std::ldexp(1.0f, -11)), 0x3C00);  // tie below: even
  EXPECT_EQ(float_to_half(1.0f + 3 * std::ldexp(1.0f, -11)), 0x3C02);
  for (float v : {0.1f, 0.5f, 3.14159f, 1000.f, 1e-5f, -7.25f})
    EXPECT_NEAR(half_to_float(float_to_half(v)), v, std::abs(v) * std::ldexp(1.0, -11) + 6e-8);
}

TEST(KTX2, RefusesValuesThatAreNotFiniteOrDoNotFit) {
  KtxTexture t;
  t.width = 2;
  t.height = 1;
  t.texels = {1.f, NAN};
  EXPECT_THROW(encode_ktx2(t), Error);
  t.texels = {1.f};
  EXPECT_THROW(encode_ktx2(t), Error);  // 1 value for 2 texels
  t.format = KtxFormat::kRGBA16Float;
  t.texels = {1.f, 1.f, 1.f, 1.f, 70000.f, 0.f, 0.f, 1.f};
  EXPECT_THROW(encode_ktx2(t), Error);  // beyond half float
}

// Our own reader and ktx-parse read the same numbers back: R32 exactly, RGBA16F to half precision.
TEST(Export, KtxTablesReadBackByAnIndependentReader) {
  const std::string dir = tmp_dir("out") + "/export";
  ExportOptions o;
  o.size = 64;
  const ExportSummary s = export_material(brushed(), dir, o);
  const BakeTables t = bake_line(brushed(), 64, BakeIndex::kAngle);
  const KtxTexture d = read_ktx2(dir + "/tables/diffuse.ktx2");
  ASSERT_EQ(d.texels.size(), t.diffuse.px.size());
  for (size_t i = 0; i < d.texels.size(); ++i) ASSERT_EQ(d.texels[i], t.diffuse.px[i]);
  const KtxTexture c = read_ktx2(dir + "/tables/combined.ktx2");
  for (size_t p = 0; p < t.combined.px.size() / 3; ++p)
    for (int k = 0; k < 3; ++k)
      ASSERT_NEAR(c.texels[4 * p + k], t.combined.px[3 * p + k],
                  std::abs(t.combined.px[3 * p + k]) * 1e-3 + 1e-7);

  int status = 0;
  const auto j =
      node_json("check_ktx2.mjs",
                "'" + dir + "/tables/diffuse.ktx2' '" + dir + "/tables/combined.ktx2'", &status);
  ASSERT_EQ(status, 0) << j.dump(2);
  const auto& jd = j[dir + "/tables/diffuse.ktx2"];
  EXPECT_EQ(jd["vkFormat"], 100);  // VK_FORMAT_R32_SFLOAT
  EXPECT_EQ(jd["width"], 64);
  EXPECT_EQ(jd["height"], 64);
  EXPECT_EQ(jd["levels"], 1);
  EXPECT_EQ(jd["supercompression"], 0);
  EXPECT_EQ(jd["dfd"]["colorModel"], 1);        // RGBSDA
  EXPECT_EQ(jd["dfd"]["transferFunction"], 1);  // linear
  EXPECT_EQ(jd["dfd"]["bytesPlane0"], 4);
  EXPECT_EQ(jd["dfd"]["samples"][0]["bitLength"], 31);
  EXPECT_EQ(jd["dfd"]["samples"][0]["channelType"], 0xC0);  // red, float, signed
  EXPECT_EQ(jd["keyValue"]["KTXorientation"], "rd");
  for (int i = 0; i < 4; ++i) EXPECT_EQ(jd["first"][i].get<double>(), t.diffuse.px[i]);
  const auto& jc = j[dir + "/tables/combined.ktx2"];
  EXPECT_EQ(jc["vkFormat"], 97);  // VK_FORMAT_R16G16B16A16_SFLOAT
  EXPECT_EQ(jc["dfd"]["bytesPlane0"], 8);
  EXPECT_EQ(jc["dfd"]["samples"].size(), 4u);
  EXPECT_EQ(jc["dfd"]["samples"][3]["channelType"], 0xCF);  // alpha, float, signed
  EXPECT_EQ(jc["levelBytes"], 64 * 64 * 8);
  EXPECT_TRUE(jc["finite"].get<bool>());
  EXPECT_GT(s.files.size(), 8u);
}

// A fiber material's map of the topology's amplitude (what `fit --model fiber --maps` writes over a
// topology map) travels with the export as KTX2 holding its texels, and the export says that its
// shaders and viewer, which take one s per call, do not draw it.
TEST(Export, AFiberMaterialsAmplitudeMapIsCarriedAndDrawn) {
  const std::string root = tmp_dir("amplitude");
  auto r = test::run_cli("synth silk-torus " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  auto j = nlohmann::json::parse(read_text_file(root + "/set/truth.json"));
  Image amp(4, 4, 1);
  for (size_t i = 0; i < amp.px.size(); ++i) amp.px[i] = 0.1f + 0.02f * i;
  write_exr(root + "/set/maps/amp.exr", amp);
  j["maps"] = {{"amplitude", "maps/amp.exr"}};
  write_json_file(root + "/set/m.json", j);
  r = test::run_cli("export " + root + "/set/m.json --out " + root + "/export --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("topology-map amplitude"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("WARNING"), std::string::npos) << r.output;
  const auto ej = nlohmann::json::parse(read_text_file(root + "/export/export.json"));
  const KtxTexture t =
      read_ktx2(root + "/export/" + ej["maps"]["amplitude"]["ktx2"].get<std::string>());
  ASSERT_EQ(t.texels.size(), amp.px.size());
  for (size_t i = 0; i < amp.px.size(); ++i) EXPECT_EQ(t.texels[i], amp.px[i]);
  EXPECT_EQ(ej["warnings"].size(), 0u) << ej["warnings"].dump();
  EXPECT_EQ(ej["maps"]["topology.map"]["wrap"], "repeat");
  // The maps' shaders take the topology map and the map of its amplitude (GLSL and HLSL).
  expect_complete_maps_shaders(root + "/export", {"anisoAmplitudeMap", "anisoTopologyMap"});
}

// A fiber material's factor tables go out as 2D arrays, no side over 8192 (a bake's stacked EXR
// is 64 x 9216), and an independent reader sees the layers.
TEST(Export, FiberTablesAreArrayTexturesWithinGpuLimits) {
  Material m = brushed();
  m.model = Model::kFiber;
  m.topology = UniformS{0.4};
  const std::string dir = tmp_dir("out") + "/export";
  ExportOptions o;
  o.size = 32;
  const ExportSummary s = export_material(m, dir, o);
  ASSERT_TRUE(s.fiber);
  int status = 0;
  const auto j =
      node_json("check_ktx2.mjs",
                "'" + dir + "/tables/fiber_G.ktx2' '" + dir + "/tables/fiber_F.ktx2'", &status);
  ASSERT_EQ(status, 0) << j.dump(2);
  const auto& g = j[dir + "/tables/fiber_G.ktx2"];
  const auto& f = j[dir + "/tables/fiber_F.ktx2"];
  EXPECT_EQ(g["layers"], s.fiber_tables.ns);
  EXPECT_EQ(f["layers"], s.fiber_tables.ns * s.fiber_tables.nk);
  for (const auto* x : {&g, &f}) {
    EXPECT_LE((*x)["width"].get<int>(), 8192);
    EXPECT_LE((*x)["height"].get<int>(), 8192);
    EXPECT_TRUE((*x)["finite"].get<bool>());
  }
  const auto ej = nlohmann::json::parse(read_text_file(dir + "/export.json"));
  EXPECT_EQ(ej["model"], "fiber");
  EXPECT_GT(ej["errors"]["fiber_tables"]["samples"].get<int>(), 0);
  // The same layers as one plain EXR each, for engines without array textures: every layer's
  // texels where the layout puts them.
  for (const char* stem : {"fiber_G", "fiber_F"}) {
    const auto& layout = ej["tables"][stem]["exr_atlas"];
    const KtxTexture k = read_ktx2(dir + "/tables/" + stem + ".ktx2");
    const Image a = read_image(dir + "/" + layout["file"].get<std::string>()).image;
    const int columns = layout["columns"], tw = layout["tile"][0], th = layout["tile"][1];
    ASSERT_EQ(tw, k.width);
    ASSERT_EQ(th, k.height);
    EXPECT_LE(a.width, 8192);
    size_t same = 0;
    for (int l = 0; l < k.layers; ++l)
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x)
          same += a.at((l % columns) * tw + x, (l / columns) * th + y, 0) ==
                  k.texels[(static_cast<size_t>(l) * th + y) * tw + x];
    EXPECT_EQ(same, static_cast<size_t>(k.layers) * tw * th) << stem;
  }
  EXPECT_EQ(ej["engines"]["written"], false);  // the packages draw the line model
}

// engines/: Godot, Unity and Unreal packages carry the material's values and compile with
// Khronos' reference compiler as each engine wraps them (the Godot shader's model part as GLSL,
// Unity's Custom Function and Unreal's Custom-node body as HLSL), then translate to Metal.
TEST(Export, EnginePackagesCarryTheMaterialAndCompile) {
  const std::string dir = tmp_dir("engines") + "/export";
  ExportOptions o;
  o.size = 64;
  export_material(brushed(), dir, o);
  const std::string e = dir + "/engines";
  const std::string godot = read_text_file(e + "/godot/aniso_line.gdshader");
  for (const char* want : {"uniform vec3 kd = vec3(0.2, 0.15, 0.1);",
                           "uniform float fiber_angle_deg = 30.0;", "ANISO_TEXELS = 64.0;"})
    EXPECT_NE(godot.find(want), std::string::npos) << want;
  const std::string tres = read_text_file(e + "/godot/aniso_line.tres");
  EXPECT_NE(tres.find("res://aniso/tables/specular.exr"), std::string::npos);
  EXPECT_NE(tres.find("shader_parameter/ks = Vector3(0.6, 0.6, 0.6)"), std::string::npos) << tres;
  EXPECT_NE(read_text_file(e + "/unreal/AnisoLine_nodes.t3d").find("Constant=(R=0.2,G=0.15,B=0.1"),
            std::string::npos);
  // Each as its engine wraps it, with a main that calls it.
  const size_t a = godot.find("// aniso-model-begin"), b = godot.find("// aniso-model-end");
  ASSERT_NE(b, std::string::npos);
  write_text_file(e + "/godot_check.frag",
                  "#version 330 core\nuniform sampler2D aniso_diffuse;\nuniform sampler2D "
                  "aniso_specular;\n" +
                      godot.substr(a, b - a) +
                      "in vec3 n;\nin vec3 t;\nout vec4 c;\nvoid main() { c = "
                      "vec4(aniso_radiance(normalize(n), t, vec3(0.0, 0.0, 1.0), vec3(0.0, 1.0, "
                      "0.0), vec3(0.2), vec3(0.5), vec3(1.0)), 1.0); }\n");
  const std::string hlsl_main =
      "Texture2D d : register(t0);\nTexture2D s : register(t1);\nSamplerState ss : "
      "register(s0);\nfloat4 main(float4 p : SV_Position, float3 n : NORMAL, float3 t : TANGENT) "
      ": SV_Target {\n";
  write_text_file(e + "/unity/check.hlsl",
                  "#include \"AnisoLine.hlsl\"\n" + hlsl_main +
                      "  float3 f, r;\n  AnisoFiberTangent_float(n, t, cross(n, t), 30.0, f);\n"
                      "  AnisoLine_float(n, f, float3(0, 0, 1), float3(1, 1, 1), float3(0, 1, 0), "
                      "float3(0.2, 0.15, 0.1), float3(0.6, 0.6, 0.6), d, s, ss, r);\n  return "
                      "float4(r, 1);\n}\n");
  write_text_file(e + "/unreal/check.hlsl",
                  "#define Texture2DSampleLevel(t, s, uv, l) t.SampleLevel(s, uv, l)\nfloat3 "
                  "CustomExpression0(float3 N, float3 T, float3 L, float3 V, float3 E, float3 Kd, "
                  "float3 Ks, Texture2D DiffuseTable, SamplerState DiffuseTableSampler, Texture2D "
                  "SpecularTable, SamplerState SpecularTableSampler) {\n" +
                      read_text_file(e + "/unreal/AnisoLine_custom_node.hlsl") + "}\n" + hlsl_main +
                      "  return float4(CustomExpression0(n, t, float3(0, 0, 1), float3(0, 1, 0), "
                      "float3(1, 1, 1), float3(0.2, 0.15, 0.1), float3(0.6, 0.6, 0.6), d, ss, s, "
                      "ss), 1);\n}\n");
  for (const char* f : {"/godot_check.frag", "/unity/check.hlsl", "/unreal/check.hlsl"}) {
    const test::RunResult r = compile_to_metal(e + f);
    EXPECT_EQ(r.status, 0) << f << ": " << r.output;
    EXPECT_NE(r.output.find("fragment main0_out main0"), std::string::npos) << f << r.output;
  }
  const auto ej = nlohmann::json::parse(read_text_file(dir + "/export.json"));
  EXPECT_EQ(ej["engines"]["written"], true);
  EXPECT_EQ(ej["engines"]["folders"].size(), 3u);
}

// The exported GLSL and HLSL compile with Khronos' reference compiler and translate to Metal.
TEST(Export, ShadersCompileForOpenGLVulkanDirect3DAndMetal) {
  const std::string dir = tmp_dir("out") + "/export";
  Material m = brushed();
  m.model = Model::kFiber;  // a fiber export carries the line files and the fiber files
  m.topology = UniformS{0.3};
  ExportOptions o;
  o.size = 64;
  export_material(m, dir, o);
  const std::string sh = dir + "/shaders/";
  for (const char* f : {"aniso_fiber.frag", "aniso_fiber_ps.hlsl", "aniso.frag", "aniso_ps.hlsl"}) {
    const auto r = compile_to_metal(sh + f);
    EXPECT_EQ(r.status, 0) << f << ": " << r.output;
    EXPECT_NE(r.output.find("fragment"), std::string::npos) << r.output;
  }
  // The function files alone, as an engine includes them.
  const auto r = run_command(
      "cd '" + sh + "' && printf '#version 330 core\\n' > inc.frag && cat " +
      "aniso_lookup.glsl >> inc.frag && printf 'out vec4 f; void main() { f = " +
      "vec4(anisoRadiance(vec3(0,0,1), vec3(1,0,0), vec3(0,0,1), vec3(0,0,1), " +
      "vec3(1), vec3(1), vec3(1)), 1.0); }\\n' >> inc.frag && glslangValidator inc.frag");
  EXPECT_EQ(r.status, 0) << r.output;
}

// A material with maps of k_d, k_s, n and the fiber direction (woven-patch, k_s given the k_d map):
// each map goes out as KTX2 that an independent reader reads back with the map's texels, the
// stack of specular tables as a 2D array holding the stack the preview draws with, and the maps'
// shaders (GLSL and HLSL, function files and complete shaders) compile with Khronos' reference
// compiler and translate to Metal.
TEST(Export, MapsTravelAsKtx2WithTheirShaders) {
  const std::string root = tmp_dir("maps_ktx2");
  auto r = test::run_cli("synth woven-patch " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  auto mj = nlohmann::json::parse(read_text_file(root + "/set/truth.json"));
  mj["maps"]["ks"] = mj["maps"]["kd"];
  write_json_file(root + "/set/m.json", mj);
  const Material m = read_material(root + "/set/m.json");
  ASSERT_TRUE(m.maps.kd && m.maps.ks && m.maps.n && m.maps.fiber);
  const std::string dir = root + "/export";
  r = test::run_cli("export " + root + "/set/m.json --out " + dir + " --size 48");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("maps per fragment"), std::string::npos) << r.output;
  const auto ej = nlohmann::json::parse(read_text_file(dir + "/export.json"));
  EXPECT_EQ(ej["maps"]["wrap"], "clamp");
  const std::string kd = dir + "/" + ej["maps"]["kd"]["ktx2"].get<std::string>();
  const std::string n = dir + "/" + ej["maps"]["n"]["ktx2"].get<std::string>();
  const std::string fib = dir + "/" + ej["maps"]["fiber"]["ktx2"].get<std::string>();
  const std::string stack = dir + "/" + ej["tables"]["specular_stack"]["ktx2"].get<std::string>();
  int status = 0;
  const auto j = node_json("check_ktx2.mjs",
                           "'" + kd + "' '" + n + "' '" + fib + "' '" + stack + "'", &status);
  ASSERT_EQ(status, 0) << j.dump(2);
  EXPECT_EQ(j[kd]["vkFormat"], 109);  // VK_FORMAT_R32G32B32A32_SFLOAT
  EXPECT_EQ(j[kd]["width"], m.maps.kd->width);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(j[kd]["first"][c].get<double>(), m.maps.kd->px[c]);
  EXPECT_EQ(j[kd]["first"][3].get<double>(), 1.0);
  EXPECT_EQ(j[n]["vkFormat"], 100);
  EXPECT_EQ(j[n]["first"][0].get<double>(), m.maps.n->px[0]);
  EXPECT_EQ(j[fib]["first"][1].get<double>(), m.maps.fiber->px[1]);  // sin 2psi of texel 0
  const SpecularStack want = bake_material_stack(m, 48, BakeIndex::kAngle);
  EXPECT_EQ(j[stack]["layers"], want.levels);
  const KtxTexture got = read_ktx2(stack);
  ASSERT_EQ(got.texels.size(), want.S.size() * want.S[0].px.size());
  for (size_t k = 0; k < want.S.size(); k += want.S.size() - 1)
    for (size_t i = 0; i < want.S[k].px.size(); i += 97)
      ASSERT_EQ(got.texels[k * want.S[0].px.size() + i], want.S[k].px[i]) << k << " " << i;
  EXPECT_NEAR(ej["tables"]["specular_stack"]["log_n0"].get<double>(), std::log(12.0), 1e-9);
  EXPECT_GT(ej["errors"]["specular_stack"]["max_abs"].get<double>(), 0.0);
  // The shaders, as the other exports' are checked.
  r = compile_to_metal(dir + "/shaders/aniso_maps.frag");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("anisoSpecularStack"), std::string::npos) << r.output;
  r = compile_to_metal(dir + "/shaders/aniso_maps_ps.hlsl");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("anisoKsMap"), std::string::npos) << r.output;
  // The function files as the browser viewer takes them, in WebGL's GLSL ES 3.00 (no implicit int
  // to float): here and with a map of n that holds one value (a stack whose step is written as
  // 1.0, a whole number).
  Image one_n(4, 4, 1);
  for (float& v : one_n.px) v = 30;
  write_exr(root + "/set/maps/one_n.exr", one_n);
  mj["maps"]["n"] = "maps/one_n.exr";
  write_json_file(root + "/set/one_n.json", mj);
  r = test::run_cli("export " + root + "/set/one_n.json --out " + root + "/one_n --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const std::string& d : {dir, root + "/one_n"}) {
    r = run_command("cd '" + d + "/shaders' && printf '#version 300 es\\nprecision highp float;" +
                    "\\nprecision highp sampler2DArray;\\n' > es.frag && cat aniso_lookup.glsl " +
                    "aniso_maps.glsl >> es.frag && printf 'out vec4 f; void main() { f = " +
                    "vec4(anisoRadianceMapped(vec3(0,0,1), vec3(1,0,0), vec2(0.5), vec3(0,0,1), " +
                    "vec3(0,0,1), vec3(1), vec3(1), vec3(1)), 1.0); }\\n' >> es.frag && " +
                    "glslangValidator es.frag");
    EXPECT_EQ(r.status, 0) << d << ": " << r.output;
  }
  // The fiber model with the same maps: F's levels over the map of n go out as a 2D array that an
  // independent reader reads back as the levels the preview draws, and the fiber files with the
  // maps' compile as the browser viewer takes them (GLSL ES 3.00) and as HLSL.
  auto fj = nlohmann::json::parse(read_text_file(root + "/set/m.json"));
  fj["model"] = "fiber";
  fj["topology"] = {{"s", 0.3}};
  write_json_file(root + "/set/fiber.json", fj);
  const Material mf = read_material(root + "/set/fiber.json");
  const std::string fdir = root + "/fiber";
  r = test::run_cli("export " + root + "/set/fiber.json --out " + fdir + " --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("not the material's map of n"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("F from"), std::string::npos) << r.output;
  const auto fe = nlohmann::json::parse(read_text_file(fdir + "/export.json"));
  const std::string fstack = fdir + "/" + fe["tables"]["fiber_F_stack"]["ktx2"].get<std::string>();
  const auto fk = node_json("check_ktx2.mjs", "'" + fstack + "'", &status);
  ASSERT_EQ(status, 0) << fk.dump(2);
  const BakeTables line = bake_line(mf, 32, BakeIndex::kAngle);
  const FiberBakeTables fb = bake_fiber(mf, line);
  const FiberStack fs =
      bake_fiber_stack(mf, fb, line, bake_material_stack(mf, 32, BakeIndex::kAngle));
  const std::vector<float> layers = fiber_stack_layers(fb, fs);
  EXPECT_EQ(fk[fstack]["layers"], fs.levels * fb.ns);
  EXPECT_EQ(fk[fstack]["width"], fb.nk * fb.nphi);
  EXPECT_TRUE(fk[fstack]["finite"].get<bool>());
  const KtxTexture ft = read_ktx2(fstack);
  ASSERT_EQ(ft.texels.size(), layers.size());
  for (size_t i = 0; i < layers.size(); i += 101) ASSERT_EQ(ft.texels[i], layers[i]) << i;
  EXPECT_GT(fe["errors"]["fiber_F_stack"]["max_abs"].get<double>(), 0.0);
  const std::string call =
      "anisoFiberRadianceMapped(N, vec3(1,0,0), vec2(0.5), N, N, 0.3, vec3(1), vec3(1), vec3(1))";
  r = run_command(
      "cd '" + fdir + "/shaders' && printf '#version 300 es\nprecision highp float;" +
      "\nprecision highp sampler2DArray;\n' > es.frag && cat aniso_lookup.glsl " +
      "aniso_fiber.glsl aniso_maps.glsl >> es.frag && printf 'out vec4 f; void main() " +
      "{ vec3 N = vec3(0,0,1); f = vec4(" + call + ", 1.0); }\n' >> es.frag && " +
      "glslangValidator es.frag");
  EXPECT_EQ(r.status, 0) << r.output;
  std::string hlsl_call = call;
  for (size_t at; (at = hlsl_call.find("vec")) != std::string::npos;)
    hlsl_call.replace(at, 3, "float");
  r = run_command("cd '" + fdir + "/shaders' && cat aniso_lookup.hlsli aniso_fiber.hlsli " +
                  "aniso_maps.hlsli > fm.hlsl && printf 'float4 main(float4 p : SV_Position) : " +
                  "SV_Target { float3 N = float3(0,0,1); return float4(" + hlsl_call +
                  ", 1.0); }\n' >> fm.hlsl");
  ASSERT_EQ(r.status, 0) << r.output;
  r = compile_to_metal(fdir + "/shaders/fm.hlsl");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("anisoFiberFStack"), std::string::npos) << r.output;
  // The complete maps shaders of a fiber material draw the fiber model (they drew the line model).
  expect_complete_maps_shaders(fdir, {"anisoFiberFStack", "uTopologyS"});
}

// The glTF passes the Khronos validator with no errors and carries the fitted anisotropy: the
// direction across the fibers (psi + 90 deg), a strength that is really anisotropic, and the
// measured lobe error.
TEST(Export, GltfPassesTheKhronosValidator) {
  const std::string dir = tmp_dir("out") + "/export";
  const ExportSummary s = export_material(brushed(), dir, ExportOptions{});
  int status = 0;
  const auto j = node_json("validate_gltf.mjs", "'" + dir + "/gltf/sample.gltf'", &status);
  EXPECT_EQ(status, 0) << j.dump(2);
  EXPECT_EQ(j["numErrors"], 0) << j.dump(2);
  const auto g = nlohmann::json::parse(read_text_file(dir + "/gltf/sample.gltf"));
  const auto& ext = g["materials"][0]["extensions"]["KHR_materials_anisotropy"];
  EXPECT_NEAR(ext["anisotropyRotation"].get<double>(), deg_to_rad(120.0), 1e-9);
  EXPECT_GT(ext["anisotropyStrength"].get<double>(), 0.3);
  EXPECT_EQ(g["materials"][0]["extras"]["aniso"]["model"], "line");
  // The anisotropic lobe beats the best isotropic one (strength 0) it was chosen over.
  const GltfPbr pbr = s.pbr;
  EXPECT_LT(pbr.lobe_rel_rms, 0.6);
  EXPECT_GE(pbr.total_rel_rms, 0.0);
  EXPECT_LE(pbr.total_rel_rms, pbr.other_rel_rms);
}

// The glTF keeps the material's colour: brushed metal (k_d brown 0.2, 0.15, 0.1; k_s grey 0.6)
// becomes a dielectric with KHR_materials_specular, its base colour k_d's hue and its specular
// colour grey, closer to the whole model than the metal it was (base colour = k_s, grey: the
// brown lost); the validator gives no error and no warning. Per texel (swirl-plate: k_d from
// copper to steel) every texel takes one mapping (none flips to metal) and the base colour keeps
// the map's hues.
TEST(Export, TheGltfKeepsTheMaterialsColour) {
  const std::string dir = tmp_dir("colour") + "/export";
  const ExportSummary s = export_material(brushed(), dir, ExportOptions{});
  int status = 0;
  auto j = node_json("validate_gltf.mjs", "'" + dir + "/gltf/sample.gltf'", &status);
  EXPECT_EQ(j["numErrors"], 0) << j.dump(2);
  EXPECT_EQ(j["numWarnings"], 0) << j.dump(2);
  const auto g = nlohmann::json::parse(read_text_file(dir + "/gltf/sample.gltf"));
  const auto& mat = g["materials"][0];
  const auto base = mat["pbrMetallicRoughness"]["baseColorFactor"];
  std::printf("brushed metal: base colour (%.3f, %.3f, %.3f), %s\n", base[0].get<double>(),
              base[1].get<double>(), base[2].get<double>(), s.pbr.mapping.c_str());
  EXPECT_EQ(mat["pbrMetallicRoughness"]["metallicFactor"].get<double>(), 0.0);
  EXPECT_NEAR(base[1].get<double>() / base[0].get<double>(), 0.15 / 0.2, 0.02);
  EXPECT_NEAR(base[2].get<double>() / base[0].get<double>(), 0.1 / 0.2, 0.02);
  ASSERT_TRUE(mat["extensions"].contains("KHR_materials_specular")) << mat.dump();
  const auto sc = mat["extensions"]["KHR_materials_specular"]["specularColorFactor"];
  EXPECT_NEAR(sc[0].get<double>(), sc[2].get<double>(), 1e-9);  // k_s is grey
  EXPECT_NE(g["extensionsUsed"].dump().find("KHR_materials_specular"), std::string::npos);
  EXPECT_TRUE(s.pbr.specular);
  EXPECT_LT(s.pbr.total_rel_rms, 0.8 * s.pbr.other_rel_rms);  // the next best (metal) by 20 %+
  // Per texel.
  const std::string root = tmp_dir("colour_texels");
  auto r = test::run_cli("synth swirl-plate " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("export " + root + "/set/truth.json --out " + root + "/export --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  j = node_json("validate_gltf.mjs", "'" + root + "/export/gltf/sample.gltf'", &status);
  EXPECT_EQ(j["numErrors"], 0) << j.dump(2);
  EXPECT_EQ(j["numWarnings"], 0) << j.dump(2);
  const auto gt = nlohmann::json::parse(read_text_file(root + "/export/gltf/sample.gltf"));
  const auto& pmr = gt["materials"][0]["pbrMetallicRoughness"];
  auto image = [&](const nlohmann::json& ref) {
    const int src = gt["textures"][ref["index"].get<int>()]["source"];
    return read_image(root + "/export/gltf/" + gt["images"][src]["uri"].get<std::string>()).image;
  };
  const Image bc = image(pmr["baseColorTexture"]), mr = image(pmr["metallicRoughnessTexture"]);
  ASSERT_TRUE(gt["materials"][0]["extensions"].contains("KHR_materials_specular"));
  const Material m = read_material(root + "/set/truth.json");
  int metal = 0;
  double rb_lo = INFINITY, rb_hi = 0, kd_lo = INFINITY, kd_hi = 0;
  for (int y = 0; y < bc.height; ++y)
    for (int x = 0; x < bc.width; ++x) {
      metal += mr.at(x, y, 2) > 0.5f;
      const double rb = srgb_decode(bc.at(x, y, 0)) / std::max(1e-3, srgb_decode(bc.at(x, y, 2)));
      rb_lo = std::min(rb_lo, rb), rb_hi = std::max(rb_hi, rb);
      const Material at = material_at(m, (x + 0.5) / bc.width, (y + 0.5) / bc.height);
      const double k = at.kd[0] / at.kd[2];
      kd_lo = std::min(kd_lo, k), kd_hi = std::max(kd_hi, k);
    }
  std::printf(
      "swirl: base colour R/B from %.2f to %.2f (k_d's from %.2f to %.2f), %d metal texels\n",
      rb_lo, rb_hi, kd_lo, kd_hi, metal);
  EXPECT_EQ(metal, 0);
  EXPECT_NEAR(rb_lo, kd_lo, 0.05 * kd_lo);
  EXPECT_NEAR(rb_hi, kd_hi, 0.05 * kd_hi);
}

// A material with a fiber map (the swirl plate's truth): the glTF gets KHR_materials_anisotropy's
// anisotropyTexture, which the Khronos validator accepts, holding psi + 90 deg per texel.
TEST(Export, FiberMapBecomesTheGltfAnisotropyTexture) {
  const std::string root = tmp_dir("maps");
  auto r = test::run_cli("synth swirl-plate " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("export " + root + "/set/truth.json --out " + root + "/export --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("anisotropyTexture"), std::string::npos) << r.output;
  int status = 0;
  const auto j = node_json("validate_gltf.mjs", "'" + root + "/export/gltf/sample.gltf'", &status);
  EXPECT_EQ(status, 0) << j.dump(2);
  EXPECT_EQ(j["numErrors"], 0) << j.dump(2);
  const auto g = nlohmann::json::parse(read_text_file(root + "/export/gltf/sample.gltf"));
  const auto& ext = g["materials"][0]["extensions"]["KHR_materials_anisotropy"];
  ASSERT_TRUE(ext.contains("anisotropyTexture")) << ext.dump();
  EXPECT_EQ(ext["anisotropyRotation"].get<double>(), 0.0);
  const Image tex =
      read_image(root + "/export/gltf/" + g["images"][0]["uri"].get<std::string>()).image;
  const Material m = read_material(root + "/set/truth.json");
  double worst = 0;
  for (int y = 0; y < tex.height; y += 7)
    for (int x = 0; x < tex.width; x += 7) {
      const double dir = std::atan2(2 * tex.at(x, y, 1) - 1, 2 * tex.at(x, y, 0) - 1);
      const Material at = material_at(m, (x + 0.5) / tex.width, (y + 0.5) / tex.height);
      double d = std::fmod(std::abs(rad_to_deg(dir) - (at.fiber_angle_deg + 90)), 180.0);
      worst = std::max(worst, std::min(d, 180 - d));
    }
  std::printf("anisotropyTexture: %dx%d, worst direction error against psi + 90 deg: %.2f deg\n",
              tex.width, tex.height, worst);
  EXPECT_LT(worst, 0.5);  // 8-bit encoding
}

// A material with maps of k_d, k_s and n (woven-patch: warp blocks red with n = 30, weft blocks
// blue with n = 12, each its own direction) becomes per-texel glTF textures: base colour (sRGB),
// metallic-roughness and the anisotropy's strength beside its direction, each within 8-bit
// rounding (and the lobe's interpolation in log n) of fit_gltf_pbr at the texel's centre; the
// Khronos validator accepts the file.
TEST(Export, MapsBecomePerTexelGltfTextures) {
  const std::string root = tmp_dir("pbr_texels");
  auto r = test::run_cli("synth woven-patch " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  const Material m = read_material(root + "/set/truth.json");
  ASSERT_TRUE(m.maps.kd && m.maps.n && m.maps.fiber);
  // In process, texels of a 12 x 12 grid (every 5th: fit_gltf_pbr takes ~0.1 s) against the
  // uniform fit at the centre.
  const GltfPbrTexels px = fit_gltf_pbr_texels(m, 12, 12);
  double d_base = 0, d_rough = 0, d_strength = 0;
  int metal_mismatch = 0, compared = 0;
  for (int y = 0; y < 12; y += 5)
    for (int x = 0; x < 12; x += 5, ++compared) {
      const size_t t = static_cast<size_t>(y) * 12 + x;
      const GltfPbr one = fit_gltf_pbr(material_at(m, (x + 0.5) / 12, (y + 0.5) / 12));
      for (int c = 0; c < 3; ++c)
        d_base = std::max(d_base, std::abs(px.base_color[3 * t + c] - one.base_color[c]));
      d_rough = std::max(d_rough, std::abs(px.roughness[t] - one.roughness));
      d_strength = std::max(d_strength, std::abs(px.strength[t] - one.strength));
      metal_mismatch += px.metallic[t] != one.metallic;
    }
  std::printf(
      "per texel against fit_gltf_pbr at the centre (%d lobe fits): base colour %.2e, "
      "roughness %.2e, strength %.2e, metallic differs in %d of %d\n",
      px.n_nodes, d_base, d_rough, d_strength, metal_mismatch, compared);
  EXPECT_GE(px.n_nodes, 2);  // n from 12 to 30
  EXPECT_LT(d_base, 1e-6);   // the nodes fall on the two n values: exact there
  EXPECT_LT(d_rough, 1e-6);
  EXPECT_LT(d_strength, 1e-6);
  EXPECT_EQ(metal_mismatch, 0);
  // The exported glTF.
  r = test::run_cli("export " + root + "/set/truth.json --out " + root + "/export --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  int status = 0;
  const auto j = node_json("validate_gltf.mjs", "'" + root + "/export/gltf/sample.gltf'", &status);
  EXPECT_EQ(status, 0) << j.dump(2);
  EXPECT_EQ(j["numErrors"], 0) << j.dump(2);
  const auto g = nlohmann::json::parse(read_text_file(root + "/export/gltf/sample.gltf"));
  const auto& pmr = g["materials"][0]["pbrMetallicRoughness"];
  ASSERT_TRUE(pmr.contains("baseColorTexture") && pmr.contains("metallicRoughnessTexture"))
      << pmr.dump();
  auto image = [&](const nlohmann::json& ref) {
    const int src = g["textures"][ref["index"].get<int>()]["source"];
    return read_image(root + "/export/gltf/" + g["images"][src]["uri"].get<std::string>()).image;
  };
  const Image base = image(pmr["baseColorTexture"]), mr = image(pmr["metallicRoughnessTexture"]);
  const Image an =
      image(g["materials"][0]["extensions"]["KHR_materials_anisotropy"]["anisotropyTexture"]);
  ASSERT_EQ(base.width, m.maps.kd->width);  // the finest of the maps' grids
  ASSERT_EQ(mr.width, base.width);
  ASSERT_EQ(an.width, base.width);
  double worst = 0;
  const int W = base.width, H = base.height;
  for (int y = 1; y < H; y += H / 3)
    for (int x = 2; x < W; x += W / 3) {
      const GltfPbr one = fit_gltf_pbr(material_at(m, (x + 0.5) / W, (y + 0.5) / H));
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, std::abs(srgb_decode(base.at(x, y, c)) - one.base_color[c]));
      worst = std::max(worst, std::abs(mr.at(x, y, 1) - one.roughness));
      worst = std::max(worst, std::abs(mr.at(x, y, 2) - one.metallic));
      worst = std::max(worst, std::abs(an.at(x, y, 2) - one.strength));
    }
  std::printf("glTF textures against fit_gltf_pbr at the texel centres: worst %.4f\n", worst);
  EXPECT_LT(worst, 0.01);  // 8-bit codes (sRGB's steepest step near black is ~0.0012)
}

// The glTF's anisotropy direction field keeps one sign across neighbours (d and -d shade alike,
// but an engine's filtering averages opposite vectors toward zero): on the swirl (fibres in
// circles, psi wrapping through 180 degrees) the pairs of neighbours that point apart, against the
// per-texel sign the export used to write.
TEST(Export, TheAnisotropyDirectionFieldIsContinuous) {
  const std::string root = tmp_dir("aniso_field");
  auto r = test::run_cli("synth swirl-plate " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("export " + root + "/set/truth.json --out " + root + "/export --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto g = nlohmann::json::parse(read_text_file(root + "/export/gltf/sample.gltf"));
  const int tex =
      g["materials"][0]["extensions"]["KHR_materials_anisotropy"]["anisotropyTexture"]["index"];
  const Image an =
      read_image(root + "/export/gltf/" +
                 g["images"][g["textures"][tex]["source"].get<int>()]["uri"].get<std::string>())
          .image;
  const Material m = read_material(root + "/set/truth.json");
  const Image& f = *m.maps.fiber;
  ASSERT_EQ(an.width, f.width);
  auto exported = [&](int x, int y) {
    return std::array<double, 2>{2.0 * an.at(x, y, 0) - 1, 2.0 * an.at(x, y, 1) - 1};
  };
  auto per_texel = [&](int x, int y) {  // the sign the export used to write
    const double dir = 0.5 * std::atan2(f.at(x, y, 1), f.at(x, y, 0)) + M_PI / 2;
    return std::array<double, 2>{std::cos(dir), std::sin(dir)};
  };
  size_t pairs = 0, apart = 0, apart_before = 0, off_line = 0;
  for (int y = 0; y < an.height; ++y)
    for (int x = 0; x < an.width; ++x) {
      const auto d = exported(x, y), o = per_texel(x, y);
      off_line += std::abs(d[0] * o[0] + d[1] * o[1]) < 0.99;  // the same line, either sign
      for (const auto& [nx, ny] : {std::pair{x + 1, y}, std::pair{x, y + 1}}) {
        if (nx >= an.width || ny >= an.height) continue;
        const auto e = exported(nx, ny), p = per_texel(nx, ny);
        ++pairs;
        apart += d[0] * e[0] + d[1] * e[1] < -0.5;
        apart_before += o[0] * p[0] + o[1] * p[1] < -0.5;
      }
    }
  std::printf(
      "swirl's anisotropy texture: neighbours pointing apart %zu of %zu pairs (per-texel "
      "sign: %zu)\n",
      apart, pairs, apart_before);
  EXPECT_EQ(off_line, 0u);
  EXPECT_GT(apart_before, 30u);  // the swirl wraps: the per-texel sign flips along a seam (62)
  EXPECT_LE(apart, 2u);          // seen: 0
}

// An export shows its progress on a terminal (a pseudo-terminal from `script` here), and nothing of
// it where stderr is not one.
TEST(Export, ShowsItsProgressOnATerminal) {
  const std::string root = tmp_dir("progress");
  auto r = test::run_cli("synth swirl-plate " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_command("script -qec \"" + std::string(ANISO_BIN) + " export " + root +
                        "/set/truth.json --out " + root + "/tty --size 32\" /dev/null");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("export: tables, maps, shaders, glTF, viewer ["), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("100%"), std::string::npos) << r.output;
  r = test::run_cli("export " + root + "/set/truth.json --out " + root + "/plain --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("%]"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("100%"), std::string::npos) << r.output;
}

// `cmake --install`: the installed commands run from their prefix (the lean aniso hands synth to
// the aniso-full beside it) and an installed export copies three.js from the prefix's own
// share/aniso/three, not from the source tree it was built in.
TEST(Export, AnInstalledAnisoRunsFromItsPrefixWithItsOwnThree) {
  const std::string root = tmp_dir("install");
  const std::string build = std::filesystem::path(ANISO_BIN).parent_path().string();
  const std::string prefix = root + "/prefix";
  auto r = run_command("cmake --install '" + build + "' --prefix '" + prefix + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* f : {"/bin/aniso", "/bin/aniso-full", "/share/aniso/three/three.module.js",
                        "/share/doc/aniso/README.md"})
    EXPECT_TRUE(std::filesystem::exists(prefix + f)) << f;
  // The prefix moved elsewhere runs from where it is now: everything is found from the binary.
  const std::string moved = root + "/moved/elsewhere";
  std::filesystem::create_directories(root + "/moved");
  std::filesystem::rename(prefix, moved);
  r = run_command("'" + moved + "/bin/aniso' --version");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("aniso 0."), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(commit "), std::string::npos) << r.output;
  r = run_command("env -u ANISO_THREE_DIR '" + moved + "/bin/aniso' synth brushed-metal '" + root +
                  "/set' --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_command("env -u ANISO_THREE_DIR '" + moved + "/bin/aniso' export '" + root +
                  "/set/truth.json' --out '" + root + "/export' --size 16");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(read_text_file(root + "/export/export.json"));
  EXPECT_NE(j["three"]["three"].get<std::string>().find(moved + "/share/aniso/three"),
            std::string::npos)
      << j["three"].dump();
  EXPECT_TRUE(std::filesystem::exists(root + "/export/three/three.module.js"));
}

// `aniso export` carries the built-in studio by default, prefiltered for the material in half
// floats, where it applies; a material it cannot carry is exported without it and export.json says
// why; --env none leaves it out; a named environment the material cannot carry is an error.
TEST(Export, TheStudioGoesWithEveryExportThatCanCarryIt) {
  const std::string root = tmp_dir("studio");
  nlohmann::json j;
  material_to_json(brushed(), &j);
  write_json_file(root + "/m.json", j);
  auto r = test::run_cli("export " + root + "/m.json --out " + root + "/line --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  auto ej = nlohmann::json::parse(read_text_file(root + "/line/export.json"));
  ASSERT_TRUE(ej["tables"].contains("environment")) << ej["tables"].dump();
  EXPECT_EQ(ej["tables"]["environment"]["source"], "studio");
  const auto& terms = ej["tables"]["environment"]["terms"];
  ASSERT_EQ(terms.size(), 7u);
  size_t bytes = 0;
  for (const auto& t : terms) {
    const std::string f = root + "/line/" + t.get<std::string>();
    EXPECT_EQ(read_ktx2(f).format, KtxFormat::kRGBA16Float) << f;
    bytes += std::filesystem::file_size(f);
  }
  std::printf("the studio's terms: %.2f MB\n", bytes / 1e6);
  EXPECT_LT(bytes, size_t(4) << 20);

  r = test::run_cli("export " + root + "/m.json --env none --out " + root + "/none --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  ej = nlohmann::json::parse(read_text_file(root + "/none/export.json"));
  EXPECT_FALSE(ej["tables"].contains("environment"));
  EXPECT_FALSE(std::filesystem::exists(root + "/none/tables/environment_t0.ktx2"));

  // A fiber material at one s carries it (the viewer's frame: Export.BrowserViewerUnderAn-
  // EnvironmentMatchesThePreview); one on a torus's topology, a shape the viewer does not have,
  // goes without.
  Material fiber = brushed();
  fiber.model = Model::kFiber;
  fiber.topology = UniformS{0.3};
  material_to_json(fiber, &j);
  write_json_file(root + "/one_s.json", j);
  r = test::run_cli("export " + root + "/one_s.json --out " + root + "/one_s --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  ej = nlohmann::json::parse(read_text_file(root + "/one_s/export.json"));
  ASSERT_TRUE(ej["tables"].contains("environment"));
  EXPECT_EQ(ej["tables"]["environment"]["model"], "fiber");
  for (const char* key : {"D", "S", "coef"})
    EXPECT_TRUE(std::filesystem::exists(
        root + "/one_s/" + ej["tables"]["environment"]["tables"][key].get<std::string>()));
  fiber.topology = MathematicalS{MathTopology::kTorus};
  material_to_json(fiber, &j);
  write_json_file(root + "/f.json", j);
  r = test::run_cli("export " + root + "/f.json --out " + root + "/fiber --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("no environment"), std::string::npos) << r.output;
  ej = nlohmann::json::parse(read_text_file(root + "/fiber/export.json"));
  EXPECT_FALSE(ej["tables"].contains("environment"));
  const std::string torus = "a mathematical topology other than the sample sphere's";
  EXPECT_NE(ej["tables"]["environment_left_out"].get<std::string>().find(torus), std::string::npos);
  r = test::run_cli("export " + root + "/f.json --env studio --out " + root +
                    "/fiber_env --size 32");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find(torus), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(root + "/fiber_env"));
  // A second fiber and an isotropic term travel with it (the viewer's frames:
  // Export.BrowserViewerUnderAnEnvironmentDrawsMapsAndTerms); a second fiber beside a map of the
  // fiber direction, which the preview does not light under an environment either, does not.
  Material iso = brushed(), woven = brushed();
  iso.has_isotropic = true;
  iso.iso_ks = {0.2, 0.2, 0.2};
  woven.has_second_fiber = true;
  EXPECT_EQ(environment_refusal(iso), "");
  EXPECT_EQ(environment_refusal(woven), "");
  woven.maps.fiber = std::make_shared<Image>(4, 4, 4, 0.0f);
  EXPECT_NE(environment_refusal(woven).find("a second fiber with a map of the fiber direction"),
            std::string::npos);
  EXPECT_EQ(environment_refusal(brushed()), "");
}

TEST(Export, RefusesAFolderThatIsNotAnEarlierExport) {
  const std::string root = tmp_dir("out");
  const std::string dir = root + "/mine";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/notes.txt") << "mine";
  EXPECT_THROW(export_material(brushed(), dir, ExportOptions{}), Error);
  EXPECT_EQ(read_text_file(dir + "/notes.txt"), "mine");
  EXPECT_FALSE(std::filesystem::exists(dir + "/export.json"));
  // An earlier export is replaced.
  const std::string ex = root + "/export";
  export_material(brushed(), ex, ExportOptions{});
  ExportOptions o;
  o.size = 32;
  const ExportSummary s = export_material(brushed(), ex, o);
  EXPECT_EQ(read_ktx2(ex + "/tables/diffuse.ktx2").width, 32);
  EXPECT_EQ(s.line.size, 32);
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// Two frames' mean absolute difference in sRGB, as a fraction of full scale, and the second's
// mean value in *lit_mean.
double mean_abs_difference(const std::string& png_a, const std::string& png_b, double* lit_mean) {
  const Image a = read_image(png_a).image, b = read_image(png_b).image;
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  if (a.width != b.width || a.height != b.height) return 1;
  double sum = 0, lit = 0;
  size_t n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int c = 0; c < 3; ++c) {
        sum += std::abs(a.at(x, y, c) - b.at(x, y, c));
        lit += b.at(x, y, c);
        ++n;
      }
  *lit_mean = lit / n;
  return sum / n;
}

// The three.js viewer's frame (headless Chromium, SwiftShader WebGL) of the export of `material`
// against `aniso preview` of `against` with the same options: the mean absolute difference in
// sRGB, as a fraction of full scale (and the preview's mean value in *lit).
double viewer_against_preview(const std::string& root, const std::string& material,
                              const std::string& against, double* lit_mean,
                              const std::string& shape = "sphere") {
  const std::string dir = root + "/export";
  if (!std::filesystem::exists(dir)) {
    const auto ex = test::run_cli("export " + material + " --out " + dir);
    EXPECT_EQ(ex.status, 0) << ex.output;
  }
  const std::string q = "shape=" + shape + "&view=0.3,-0.8,0.5&light=0.6,-0.1,0.8&size=200x160";
  if (!std::filesystem::exists(root + "/web.png")) {
    const auto shot = run_command("'" + web_dir() + "/screenshot.sh' '" + dir + "' '" + q + "' '" +
                                  root + "/web.png' 200 160");
    EXPECT_EQ(shot.status, 0) << shot.output;
    EXPECT_NE(shot.output.find("aniso viewer: rendered"), std::string::npos) << shot.output;
  }
  const std::string png = root + "/pv_" + std::filesystem::path(against).stem().string() + ".png";
  const auto pv = test::run_cli("preview " + against + " --shape " + shape +
                                " --view 0.3,-0.8,0.5 --light 0.6,-0.1,0.8 "
                                "--size 200x160 --out " +
                                png);
  EXPECT_EQ(pv.status, 0) << pv.output;
  return mean_abs_difference(root + "/web.png", png, lit_mean);
}

// Real engines' own glTF loaders (three.js GLTFLoader, Babylon.js, the Khronos glTF Sample
// Renderer) render the exported glTF under `aniso preview`'s camera and lights (web/engines.js),
// and `export --engines` records each frame against the exact model's, and three.js against the
// other two, in export.json. The glTF's lobe is GGX fitted to the model's (a whole-model relative
// RMS of 0.36 for this material, export.json errors.gltf), so the engines stand further from the
// exact model than the export's own viewer (0.0001) but close to each other.
TEST(Export, BrowserEnginesRenderTheGltfAsThePreview) {
  const std::string root = test::tmp_dir("engines_render");
  Material m = brushed();
  nlohmann::json j;
  material_to_json(m, &j);
  write_json_file(root + "/m.json", j);
  auto r = test::run_cli("export " + root + "/m.json --engines --out " + root + "/export");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("engines against aniso preview"), std::string::npos) << r.output;
  const auto e = nlohmann::json::parse(read_text_file(root + "/export/export.json"));
  ASSERT_TRUE(e.contains("engines_measured")) << e.dump();
  const auto& measured = e["engines_measured"];
  for (const char* engine : {"three", "babylon", "khronos"}) {
    const auto& x = measured["engines"][engine];
    ASSERT_TRUE(x["rendered"].get<bool>()) << engine << ": " << x.dump();
    const double d = x["mean_abs_difference"].get<double>(), lit = x["preview_mean"].get<double>();
    std::printf(
        "%s vs aniso preview (the exact model): mean |diff| %.4f of full scale (preview mean "
        "%.3f)\n",
        engine, d, lit);
    EXPECT_GT(lit, 0.1);
    // A blank or unlit frame would stand the preview's mean away: the engine drew the sphere.
    EXPECT_LT(d, 0.05);
  }
  for (const char* other : {"babylon", "khronos"}) {
    const double between = measured["three_against"][other].get<double>();
    std::printf("three.js vs %s: mean |diff| %.4f\n", other, between);
    EXPECT_LT(between, 0.03);
  }
  // Without the repository's web/, --engines says what it needs and writes nothing.
  r = test::run_command("ANISO_WEB_DIR='" + root + "/nowhere' " + std::string(ANISO_BIN) +
                        " export " + root + "/m.json --engines --out " + root + "/export2");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("npm packages"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(root + "/export2"));
}

// A material with maps on the flat sample (swirl-plate's fiber and k_d maps): the browser viewer
// draws the frame `aniso preview --shape flat` draws, within 2 % of full scale.
TEST(Export, BrowserViewerDrawsTheFlatSampleAsThePreviewDoes) {
  const std::string root = test::tmp_dir("viewer_flat");
  auto r = test::run_cli("synth swirl-plate " + root + "/set --size 16x16 --views 1");
  ASSERT_EQ(r.status, 0) << r.output;
  double lit = 0;
  const double mad = viewer_against_preview(root, root + "/set/truth.json",
                                            root + "/set/truth.json", &lit, "flat");
  std::printf(
      "browser viewer on the flat sample against aniso preview --shape flat: mean |diff| "
      "%.4f of full scale (preview mean %.3f)\n",
      mad, lit);
  EXPECT_LT(mad, 0.02);
  EXPECT_GT(lit, 0.05);  // the sample fills the frame: a blank render would pass the difference
}

// The cylinder (a brushed rod): the browser viewer draws `aniso preview --shape cylinder`'s frame,
// the open tube's inside included, and not the sphere's.
TEST(Export, BrowserViewerDrawsTheCylinderAsThePreviewDoes) {
  const std::string root = test::tmp_dir("viewer_cylinder");
  nlohmann::json j;
  material_to_json(brushed(), &j);
  write_json_file(root + "/m.json", j);
  double lit = 0;
  const double mad =
      viewer_against_preview(root, root + "/m.json", root + "/m.json", &lit, "cylinder");
  std::printf(
      "browser viewer on the cylinder against aniso preview --shape cylinder: mean |diff| "
      "%.4f of full scale (preview mean %.3f)\n",
      mad, lit);
  EXPECT_LT(mad, 0.02);
  EXPECT_GT(lit, 0.05);
  double lit_sphere = 0;
  const auto pv = test::run_cli("preview " + root +
                                "/m.json --shape sphere --view 0.3,-0.8,0.5 "
                                "--light 0.6,-0.1,0.8 --size 200x160 --out " +
                                root + "/sphere.png");
  ASSERT_EQ(pv.status, 0) << pv.output;
  EXPECT_GT(mean_abs_difference(root + "/web.png", root + "/sphere.png", &lit_sphere), 5 * mad);
}

// `aniso export --env studio` carries the environment's prefiltered terms, and the browser viewer
// lit by them (env=1) draws the frame `aniso preview --env studio` draws: for a line material's
// seven terms (half floats), for a material with maps (woven-patch's k_d, n and fiber direction),
// a second fiber (woven cloth), an isotropic term, and the fiber model
// (shaders/aniso_environment_fiber.glsl over its three volumes) at one s, over the sample sphere's
// mathematical topology, and with maps and a map of n, each on its own shape.
TEST(Export, BrowserViewerUnderAnEnvironmentDrawsMapsAndTerms) {
  const std::string root = test::tmp_dir("viewer_env_terms");
  // The presets' truths with their maps on disk; the others written beside them.
  for (const char* preset : {"woven-patch", "woven-cloth"}) {
    const auto r = test::run_cli("synth " + std::string(preset) + " " + root + "/" + preset +
                                 " --size 16x16 --views 1");
    ASSERT_EQ(r.status, 0) << r.output;
  }
  auto write = [](const Material& m, const std::string& path) {
    nlohmann::json j;
    material_to_json(m, &j);
    write_json_file(path, j);
  };
  write(brushed(), root + "/brushed.json");
  Material iso = brushed();
  iso.has_isotropic = true;
  iso.iso_kd = {0.05, 0.04, 0.03};
  iso.iso_ks = {0.3, 0.3, 0.3};
  iso.iso_n = 40;
  write(iso, root + "/iso.json");
  Material fiber_woven = read_material(root + "/woven-patch/truth.json");
  fiber_woven.model = Model::kFiber;
  fiber_woven.topology = UniformS{0.3};
  write(fiber_woven, root + "/woven-patch/fiber.json");
  ASSERT_TRUE(read_material(root + "/woven-cloth/truth.json").second_active());
  Material fiber = brushed();
  fiber.model = Model::kFiber;
  fiber.topology = UniformS{0.3};
  write(fiber, root + "/fiber.json");
  fiber.topology = MathematicalS{MathTopology::kSphere};
  write(fiber, root + "/fiber_sphere.json");
  const std::tuple<const char*, std::string, const char*> cases[] = {
      {"brushed", root + "/brushed.json", "sphere"},
      {"woven", root + "/woven-patch/truth.json", "flat"},
      {"cloth", root + "/woven-cloth/truth.json", "sphere"},
      {"iso", root + "/iso.json", "sphere"},
      {"fiber", root + "/fiber.json", "sphere"},
      {"fiber_sphere", root + "/fiber_sphere.json", "sphere"},
      {"fiber_woven", root + "/woven-patch/fiber.json", "flat"}};
  for (const auto& [name, material, shape] : cases) {
    const std::string dir = root + "/" + name;
    auto r = test::run_cli("export " + material + " --out " + dir + "/export --size 64");
    ASSERT_EQ(r.status, 0) << r.output;
    const auto ej = nlohmann::json::parse(read_text_file(dir + "/export/export.json"));
    ASSERT_TRUE(ej["tables"].contains("environment")) << name << ": " << ej["tables"].dump();
    if (ej["tables"]["environment"].contains("terms")) {  // seven terms, a layer per level of b
      const auto& env = ej["tables"]["environment"];
      ASSERT_EQ(env["terms"].size(), 7u);
      const KtxTexture t0 = read_ktx2(dir + "/export/" + env["terms"][0].get<std::string>());
      EXPECT_EQ(t0.layers, env["layers"].get<int>());
      EXPECT_EQ(t0.format, KtxFormat::kRGBA16Float);
    }
    if (ej["tables"]["environment"]["model"] == "fiber") {  // its coefficients in 32-bit floats
      const KtxTexture coef = read_ktx2(
          dir + "/export/" + ej["tables"]["environment"]["tables"]["coef"].get<std::string>());
      EXPECT_EQ(coef.format, KtxFormat::kRGBA32Float);
    }
    const std::string view = "0.3,-0.8,0.5";
    const std::string q = "env=1&shape=" + std::string(shape) + "&view=" + view + "&size=200x160";
    const auto shot = run_command("'" + web_dir() + "/screenshot.sh' '" + dir + "/export' '" + q +
                                  "' '" + dir + "/web.png' 200 160");
    ASSERT_EQ(shot.status, 0) << shot.output;
    EXPECT_NE(shot.output.find("aniso viewer: rendered"), std::string::npos) << shot.output;
    r = test::run_cli("preview " + material + " --env studio --shape " + shape + " --view " + view +
                      " --size 200x160 --out " + dir + "/preview.png");
    ASSERT_EQ(r.status, 0) << r.output;
    double lit = 0;
    const double mad = mean_abs_difference(dir + "/web.png", dir + "/preview.png", &lit);
    std::printf(
        "%s under the studio: browser viewer against aniso preview --env: mean |diff| %.4f of "
        "full scale (preview mean %.3f)\n",
        name, mad, lit);
    EXPECT_LT(mad, 0.02) << name;
    EXPECT_GT(lit, 0.05) << name;
  }
}

// The three.js viewer in headless Chromium (SwiftShader WebGL) renders the frame `aniso preview`
// renders with the same options: mean absolute difference at most 2 % of full scale.
// The fiber model over the sphere's mathematical topology (s_math per fragment from the sample
// sphere's position) likewise, and at least 3x as far from the same material at one s.
TEST(Export, BrowserViewerMatchesThePreview) {
  for (const char* kind : {"line", "fiber", "fiber-sphere-topology"}) {
    const std::string root = test::tmp_dir(kind);
    const bool fiber = std::string(kind) != "line";
    const bool sphere = std::string(kind) == "fiber-sphere-topology";
    Material m = brushed();
    if (fiber) {
      m.model = Model::kFiber;
      m.topology = UniformS{0.3};
    }
    auto write = [&](const Material& x, const std::string& path) {
      nlohmann::json j;
      material_to_json(x, &j);
      write_json_file(path, j);
    };
    write(m, root + "/one_s.json");
    if (sphere) m.topology = MathematicalS{MathTopology::kSphere};
    write(m, root + "/m.json");
    double lit = 0;
    const double mad = viewer_against_preview(root, root + "/m.json", root + "/m.json", &lit);
    std::printf(
        "%s: browser viewer vs aniso preview, 200x160: mean abs difference %.4f of full scale "
        "(mean value %.3f)\n",
        kind, mad, lit);
    EXPECT_LE(mad, 0.02);
    EXPECT_GT(lit, 0.1);
    if (sphere) {
      double lit_one_s = 0;
      const double mad_one_s =
          viewer_against_preview(root, root + "/m.json", root + "/one_s.json", &lit_one_s);
      std::printf("%s: vs the preview at one s %.4f\n", kind, mad_one_s);
      EXPECT_GE(mad_one_s, 3 * mad);
    }
  }
}

// A material with maps is drawn per fragment in the browser from the exported maps and shaders
// (shaders/aniso_maps.glsl; with a map of n, S from the exported stack of tables): its frame
// matches `aniso preview` of the same material (which draws the maps per fragment) within 2 % of
// full scale, and stands at least 3x as far from the preview of the material at its mean values.
// woven-patch has maps of k_d, n and the fiber direction; swirl-plate of k_d and the fiber
// direction; the fiber model takes the swirl's maps and woven-patch's (with its map of n: S and F
// from their levels over log n) with one topology s, and the swirl's with a map of s and with a
// topology map and a map of its amplitude, each also at least 3x as far from one s.
TEST(Export, BrowserViewerDrawsTheMapsPerFragment) {
  for (const char* preset : {"woven-patch", "swirl-plate", "fiber", "fiber-woven", "fiber-s-map",
                             "fiber-topology-map"}) {
    const std::string root = test::tmp_dir(std::string("viewer_maps_") + preset);
    const std::string name = preset;
    const bool fiber = name.rfind("fiber", 0) == 0, woven = name.find("woven") != std::string::npos;
    auto r = test::run_cli(std::string("synth ") + (woven ? "woven-patch" : "swirl-plate") + " " +
                           root + "/set --size 16x16 --views 1");
    ASSERT_EQ(r.status, 0) << r.output;
    auto j = nlohmann::json::parse(read_text_file(root + "/set/truth.json"));
    if (fiber) {
      j["model"] = "fiber";
      j["topology"] = {{"s", 0.3}};
    }
    write_json_file(root + "/set/m.json", j);
    // The topology over uv (flat: s_math 0): stripes of s across u, or a topology map's stripes
    // (h 0 and 1, so m = -1 and 1) at an amplitude that varies with v.
    const bool s_map = name == "fiber-s-map", topo_map = name == "fiber-topology-map";
    if (s_map || topo_map) {
      Image t(8, 8, 1);
      for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x)
          t.px[y * 8 + x] = s_map ? (x < 4 ? 0.05f : 0.75f) : (x % 4 < 2 ? 0.f : 1.f);
      write_exr(root + "/set/maps/topo.exr", t);
      if (s_map) {
        j["topology"] = {{"s_map", "maps/topo.exr"}};
      } else {
        Image a(4, 4, 1);
        for (size_t i = 0; i < a.px.size(); ++i) a.px[i] = 0.4f + 0.08f * float(i / 4);
        write_exr(root + "/set/maps/amp.exr", a);
        j["topology"] = {{"map", "maps/topo.exr"}, {"amplitude", 0.6}, {"mathematical", "none"}};
        j["maps"]["amplitude"] = "maps/amp.exr";
      }
      auto one_s = j;  // what the topology's maps add to the image
      one_s["topology"] = {{"s", 0.3}};
      one_s["maps"].erase("amplitude");
      write_json_file(root + "/set/one_s.json", one_s);
      write_json_file(root + "/set/m.json", j);
    }
    if (j["maps"].contains("n")) {  // the same maps but n: what the map of n adds to the image
      auto one_n = j;
      one_n["maps"].erase("n");
      write_json_file(root + "/set/one_n.json", one_n);
    }
    j.erase("maps");
    write_json_file(root + "/set/mean.json", j);
    double lit = 0, lit_mean = 0;
    const double mad =
        viewer_against_preview(root, root + "/set/m.json", root + "/set/m.json", &lit);
    const nlohmann::json info = nlohmann::json::parse(read_text_file(root + "/export/export.json"));
    ASSERT_TRUE(info["shaders"]["maps"].is_array()) << info["shaders"].dump();
    EXPECT_EQ(info["tables"].contains("specular_stack"), woven);
    EXPECT_EQ(info["tables"].contains("fiber_F_stack"), woven && fiber);
    const double mad_mean =
        viewer_against_preview(root, root + "/set/m.json", root + "/set/mean.json", &lit_mean);
    std::printf(
        "%s: browser viewer with maps vs aniso preview with maps, 200x160: mean abs difference "
        "%.4f of full scale (mean value %.3f); vs the preview at the mean values %.4f\n",
        preset, mad, lit, mad_mean);
    EXPECT_LE(mad, 0.02);
    EXPECT_GT(lit, 0.05);
    EXPECT_GE(mad_mean, 3 * mad);
    if (woven) {  // drawn with its map of n, not at the material's one n
      double lit_one_n = 0;
      const double mad_one_n =
          viewer_against_preview(root, root + "/set/m.json", root + "/set/one_n.json", &lit_one_n);
      std::printf("%s: vs the preview with the same maps but one n %.4f\n", preset, mad_one_n);
      EXPECT_GE(mad_one_n, 3 * mad);
    }
    if (s_map || topo_map) {  // drawn with its topology over uv, not at one s
      double lit_one_s = 0;
      const double mad_one_s =
          viewer_against_preview(root, root + "/set/m.json", root + "/set/one_s.json", &lit_one_s);
      std::printf("%s: vs the preview with the same maps but one s %.4f\n", preset, mad_one_s);
      EXPECT_GE(mad_one_s, 3 * mad);
    }
  }
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

using test::run_command;

// aniso report: the page's numbers are the fit's (each parameter's value, every cell of the
// correlation heat map), the maps' previews and each view's residual picture are beside it, and
// the folder is written once, never over a person's files.
TEST(Report, ThePagesNumbersAreTheFits) {
  const std::string dir = test::tmp_dir("report");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --out " + dir + "/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("report " + dir + "/m.json --capture " + dir + "/set --out " + dir + "/rep");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("8 views"), std::string::npos) << r.output;
  const std::string page = read_text_file(dir + "/rep/index.html");
  const auto j = nlohmann::json::parse(read_text_file(dir + "/m.json"));
  // Each parameter's value cell: data-key='KEY'>v1 v2 v3<
  for (const char* k : {"kd", "ks", "n", "fiber_angle_deg"}) {
    const std::string tag = std::string("data-key='") + k + "'>";
    const size_t at = page.find(tag);
    ASSERT_NE(at, std::string::npos) << k;
    std::istringstream cell(page.substr(at + tag.size(), page.find('<', at) - at - tag.size()));
    nlohmann::json want = j[k];
    if (!want.is_array()) want = nlohmann::json::array({j[k]});
    for (const auto& w : want) {
      double v = NAN;
      cell >> v;
      EXPECT_NEAR(v, w.get<double>(), 1e-5 * std::abs(w.get<double>())) << k;
    }
  }
  // Every cell of the heat map, row by row, is the report's correlation.
  const std::string svg = read_text_file(dir + "/rep/correlation.svg");
  std::vector<double> cells;
  for (size_t at = svg.find("data-value='"); at != std::string::npos;
       at = svg.find("data-value='", at + 1))
    cells.push_back(std::stod(svg.substr(at + 12)));
  const auto& m = j["report"]["correlation"]["matrix"];
  ASSERT_EQ(cells.size(), m.size() * m.size());
  for (size_t i = 0; i < m.size(); ++i)
    for (size_t k = 0; k < m.size(); ++k)
      EXPECT_NEAR(cells[i * m.size() + k], m[i][k].get<double>(), 1e-5);
  for (const char* f :
       {"maps/kd.png", "maps/fiber.png", "views/residual_000.png", "views/residual_007.png",
        "maps/uncertainty_fiber.png", "maps/uncertainty_coverage.png"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/rep/" + f)) << f;
  // The direction field's first glyph is texel (0, 0)'s fiber angle (a glyph per texel here).
  const std::string field = read_text_file(dir + "/rep/maps/direction_field.svg");
  EXPECT_NE(field.find("data-glyphs='48'"), std::string::npos);
  const Image fiber = read_image(dir + "/" + j["maps"]["fiber"].get<std::string>()).image;
  const double psi0 = std::fmod(90 / M_PI * std::atan2(fiber.px[1], fiber.px[0]) + 180, 180);
  const size_t g = field.find("data-psi='");
  ASSERT_NE(g, std::string::npos);
  EXPECT_NEAR(std::stod(field.substr(g + 10)), psi0, 0.006) << field.substr(g, 30);
  // The convergence plot holds the report's costs, which never rise.
  const auto& cost = j["report"]["convergence"]["cost"];
  ASSERT_GE(cost.size(), 2u);
  for (size_t i = 1; i < cost.size(); ++i)
    EXPECT_LE(cost[i].get<double>(), cost[i - 1].get<double>());
  const std::string conv = read_text_file(dir + "/rep/convergence.svg");
  EXPECT_NE(conv.find("data-steps='" + std::to_string(cost.size() - 1) + "'"), std::string::npos)
      << conv.substr(0, 300);
  // A folder of a person's is not written over.
  std::filesystem::create_directories(dir + "/mine");
  std::ofstream(dir + "/mine/notes.txt") << "mine";
  r = test::run_cli("report " + dir + "/m.json --out " + dir + "/mine");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_EQ(read_text_file(dir + "/mine/notes.txt"), "mine");
  // fit --report: the same page of what the fit just wrote.
  r = test::run_cli("fit " + dir + "/set --report " + dir + "/fitrep --out " + dir + "/f.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(read_text_file(dir + "/fitrep/index.html").find("Each view against the model"),
            std::string::npos);
  // Not a material: named.
  r = test::run_cli("report " + dir + "/set/capture.json --out " + dir + "/rep2");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("not a material file"), std::string::npos) << r.output;
}

// One figure's data- attribute, each occurrence in order.
std::vector<double> svg_values(const std::string& svg, const std::string& key) {
  std::vector<double> v;
  const std::string tag = key + "='";
  for (size_t at = svg.find(tag); at != std::string::npos; at = svg.find(tag, at + 1))
    v.push_back(std::stod(svg.substr(at + tag.size())));
  return v;
}

// The residual histogram and the lobe against the data say whether the model describes the
// capture: a fit of brushed metal leaves unit Gaussian residuals and a lobe on its data; the same
// material with k_s 20 % low does neither.
TEST(Report, TheResidualsAndTheLobeSayWhetherTheModelFits) {
  const std::string dir = test::tmp_dir("report_lobe");
  auto r = test::run_cli("synth brushed-metal " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --out " + dir + "/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  auto j = nlohmann::json::parse(read_text_file(dir + "/m.json"));
  for (auto& k : j["ks"]) k = 0.8 * k.get<double>();
  j.erase("written_by");
  write_json_file(dir + "/low.json", j);
  struct Figures {
    double sd, within1;
    std::vector<double> misfit, count;
  };
  auto figures = [&](const std::string& material, const std::string& out) {
    const auto rr = test::run_cli("report " + material + " --capture " + dir + "/set --out " + out);
    EXPECT_EQ(rr.status, 0) << rr.output;
    const std::string h = read_text_file(out + "/residual_histogram.svg"),
                      l = read_text_file(out + "/lobe.svg");
    return Figures{svg_values(h, "data-std").at(0), svg_values(h, "data-within1").at(0),
                   svg_values(l, "data-misfit"), svg_values(l, "data-count")};
  };
  const Figures fit = figures(dir + "/m.json", dir + "/rep"),
                low = figures(dir + "/low.json", dir + "/rep_low");
  std::printf("fit: std %.3f, within 1 sigma %.3f; k_s 20%% low: std %.3f\n", fit.sd, fit.within1,
              low.sd);
  EXPECT_NEAR(fit.sd, 1.0, 0.1);
  EXPECT_NEAR(fit.within1, 0.683, 0.05);
  EXPECT_GT(low.sd, 1.3 * fit.sd);
  ASSERT_EQ(fit.misfit.size(), 4u);
  double worst = 0, worst_low = 0;
  for (size_t k = 0; k < fit.misfit.size(); ++k) {
    std::printf("lobe panel %zu: %g points, misfit %.4f (k_s low: %.4f)\n", k, fit.count[k],
                fit.misfit[k], low.misfit[k]);
    EXPECT_GT(fit.count[k], 200);
    worst = std::max(worst, fit.misfit[k]), worst_low = std::max(worst_low, low.misfit[k]);
  }
  EXPECT_LT(worst, 0.02);
  EXPECT_GT(worst_low, 5 * worst);
}

// ... and headless Chromium opens it from the folder (no server, no network): every section and
// every picture loads.
TEST(Report, ThePageOpensInHeadlessChromium) {
  const std::string dir = test::tmp_dir("report_chromium");
  auto r = test::run_cli("synth brushed-metal " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --out " + dir + "/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("report " + dir + "/m.json --capture " + dir + "/set --out " + dir + "/rep");
  ASSERT_EQ(r.status, 0) << r.output;
  // The page counts its images that loaded into its title once they have.
  const std::string dom =
      run_command(
          "timeout 120 chromium --headless=new --no-sandbox --disable-gpu --user-data-dir='" + dir +
          "/profile' --virtual-time-budget=5000 --dump-dom 'file://" + dir +
          "/rep/index.html' 2>/dev/null")
          .output;
  for (const char* h :
       {"<title>aniso report: m.json</title>", "<h2>Parameters</h2>",
        "<h2>Correlation of the fitted numbers</h2>", "<h2>Each view against the model</h2>",
        "<h2>Convergence</h2>", "<h2>Residuals against the images' noise</h2>",
        "<h2>The lobe against the data</h2>"})
    EXPECT_NE(dom.find(h), std::string::npos) << h << "\n" << dom.substr(0, 2000);
  EXPECT_NE(dom.find("data-loaded=\"all\""), std::string::npos) << dom.substr(0, 2000);
  EXPECT_NE(dom.find("data-errors=\"none\""), std::string::npos) << dom.substr(0, 2000);
}

}  // namespace
}  // namespace aniso
