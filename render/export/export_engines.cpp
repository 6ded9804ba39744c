#include "render/export/export_engines.h"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "render/shaders_embedded.h"

namespace aniso {

namespace {

using json = nlohmann::json;

std::string triple(const RGB& c, const char* sep = ", ") {
  return shader_float(c[0]) + sep + shader_float(c[1]) + sep + shader_float(c[2]);
}

// The template with {{TEXELS}}, {{KD}}, {{KS}} and {{PSI}} filled in.
std::string fill(std::string t, const Material& m, int texels) {
  const std::pair<const char*, std::string> keys[] = {{"{{TEXELS}}", shader_float(texels)},
                                                      {"{{KD}}", triple(m.kd)},
                                                      {"{{KS}}", triple(m.ks)},
                                                      {"{{PSI}}", shader_float(m.fiber_angle_deg)}};
  for (const auto& [key, value] : keys)
    for (size_t at = t.find(key); at != std::string::npos; at = t.find(key, at + value.size()))
      t.replace(at, std::string(key).size(), value);
  return t;
}

// Godot's material resource: the shader with the export's two tables and the material's values,
// the export folder taken to be res://aniso/.
std::string godot_material(const Material& m) {
  return "[gd_resource type=\"ShaderMaterial\" load_steps=4 format=3]\n\n"
         "[ext_resource type=\"Shader\" path=\"res://aniso/engines/godot/aniso_line.gdshader\" "
         "id=\"1_shader\"]\n"
         "[ext_resource type=\"Texture2D\" path=\"res://aniso/tables/diffuse.exr\" "
         "id=\"2_diffuse\"]\n"
         "[ext_resource type=\"Texture2D\" path=\"res://aniso/tables/specular.exr\" "
         "id=\"3_specular\"]\n\n"
         "[resource]\nshader = ExtResource(\"1_shader\")\n"
         "shader_parameter/aniso_diffuse = ExtResource(\"2_diffuse\")\n"
         "shader_parameter/aniso_specular = ExtResource(\"3_specular\")\n"
         "shader_parameter/kd = Vector3(" +
         triple(m.kd) + ")\nshader_parameter/ks = Vector3(" + triple(m.ks) +
         ")\nshader_parameter/fiber_angle_deg = " + shader_float(m.fiber_angle_deg) + "\n";
}

// Unreal's copy-paste text of the Custom node (with the body) and the material's two colours, to
// paste into a material function's graph and wire as docs/engines.md says.
std::string unreal_nodes(const Material& m, const std::string& body) {
  std::string code;
  for (char c : body) {
    if (c == '\n')
      code += "\\r\\n";
    else if (c == '"')
      code += "\\\"";
    else
      code += c;
  }
  std::string t =
      "Begin Object Class=/Script/Engine.MaterialExpressionCustom "
      "Name=\"MaterialExpressionCustom_AnisoLine\"\n   Code=\"" +
      code + "\"\n   OutputType=CMOT_Float3\n   Description=\"aniso line model\"\n";
  const char* inputs[] = {"N", "T", "L", "V", "E", "Kd", "Ks", "DiffuseTable", "SpecularTable"};
  for (int i = 0; i < 9; ++i)
    t += "   Inputs(" + std::to_string(i) + ")=(InputName=\"" + inputs[i] + "\")\n";
  t += "End Object\n";
  for (const auto& [name, c] : {std::pair{"Kd", m.kd}, {"Ks", m.ks}})
    t += std::string(
             "Begin Object Class=/Script/Engine.MaterialExpressionConstant3Vector "
             "Name=\"MaterialExpressionConstant3Vector_") +
         name + "\"\n   Constant=(R=" + shader_float(c[0]) + ",G=" + shader_float(c[1]) +
         ",B=" + shader_float(c[2]) + ",A=0.0)\n   Desc=\"" + name + "\"\nEnd Object\n";
  return t;
}

std::string unity_howto(const Material& m) {
  return "# aniso in Unity (Shader Graph)\n\n"
         "1. Copy `AnisoLine.hlsl` and the export's `tables/diffuse.exr`, `tables/specular.exr` "
         "into Assets. Import both tables with sRGB off, compression none, mipmaps off, wrap "
         "clamp, filter bilinear.\n"
         "2. In a Shader Graph (URP, Unlit), add a Custom Function node: Type File, Source "
         "`AnisoLine.hlsl`, Name `AnisoLine`. Inputs in this order: Normal, Tangent, "
         "LightDirection, LightColor, ViewDirection, Kd, Ks (Vector 3), DiffuseTable, "
         "SpecularTable (Bare Texture 2D), LinearClamp (Bare Sampler State); output Radiance "
         "(Vector 3) into Base Color.\n"
         "3. Feed Normal and ViewDirection (World), LightDirection and LightColor from a "
         "main-light "
         "node (a Custom Function calling URP's `GetMainLight()`), and Tangent from a second "
         "Custom Function, `AnisoFiberTangent`, with the world normal, tangent, bitangent and "
         "FiberAngleDeg " +
         shader_float(m.fiber_angle_deg) + ".\n4. Kd (" + triple(m.kd) + ") and Ks (" +
         triple(m.ks) +
         ") as Vector 3 properties.\n\nNot compiled by Unity here: the function is compiled by "
         "glslangValidator's HLSL front end in aniso's tests.\n";
}

std::string unreal_howto() {
  return "# aniso in Unreal\n\n"
         "1. Import the export's `tables/diffuse.exr` and `tables/specular.exr`: compression HDR, "
         "sRGB off, mip gen none, tiling clamp, filter bilinear.\n"
         "2. In a material (Shading Model Unlit) or a material function, paste "
         "`AnisoLine_nodes.t3d` (select all, copy, paste in the graph): a Custom node whose body "
         "is "
         "`AnisoLine_custom_node.hlsl`, and the material's k_d and k_s.\n"
         "3. Wire N (VertexNormalWS), T (the world tangent turned by the fiber angle about the "
         "normal), L (toward the light: a vector parameter or the sky light's direction), V "
         "(CameraVector), E (the light's irradiance), Kd, Ks, and the two tables as Texture "
         "Objects; the result into Emissive Color.\n\nNot compiled by Unreal here: the body is "
         "compiled by glslangValidator's HLSL front end in aniso's tests, wrapped as Unreal wraps "
         "a Custom node.\n";
}

}  // namespace

std::string shader_float(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.9g", v);
  std::string t = b;
  return t.find_first_of(".e") == std::string::npos ? t + ".0" : t;
}

std::vector<std::pair<std::string, std::string>> engine_packages(const Material& m, int texels,
                                                                 json* entry) {
  if (m.fiber() || m.maps.any()) {
    *entry = {{"written", false},
              {"why", std::string(m.fiber() ? "the fiber model" : "a material with maps") +
                          ": the packages draw the line model with one set of values; shaders/ "
                          "holds what an engine needs (docs/engines.md)"}};
    return {};
  }
  const std::string body = fill(shaders::engine_unreal_body_hlsl, m, texels);
  std::vector<std::pair<std::string, std::string>> files = {
      {"engines/godot/aniso_line.gdshader", fill(shaders::engine_godot_gdshader, m, texels)},
      {"engines/godot/aniso_line.tres", godot_material(m)},
      {"engines/unity/AnisoLine.hlsl", fill(shaders::engine_unity_hlsl, m, texels)},
      {"engines/unity/HOWTO.md", unity_howto(m)},
      {"engines/unreal/AnisoLine_custom_node.hlsl", body},
      {"engines/unreal/AnisoLine_nodes.t3d", unreal_nodes(m, body)},
      {"engines/unreal/HOWTO.md", unreal_howto()}};
  json folders = json::object();
  folders["godot"] = {
      {"files", {"engines/godot/aniso_line.gdshader", "engines/godot/aniso_line.tres"}},
      {"use", "the export folder at res://aniso/; the material resource aniso_line.tres"},
      {"checked",
       "the model's part (between aniso-model-begin and -end) compiled by "
       "glslangValidator in the tests; the Godot wrapper (uniform hints, vertex(), "
       "light()) not compiled: no Godot here"}};
  folders["unity"] = {
      {"files", {"engines/unity/AnisoLine.hlsl", "engines/unity/HOWTO.md"}},
      {"use", "Shader Graph Custom Function, File mode, AnisoLine_float (HOWTO.md)"},
      {"checked",
       "compiled by glslangValidator's HLSL front end in the tests; not by Unity: no "
       "Unity here"}};
  folders["unreal"] = {{"files",
                        {"engines/unreal/AnisoLine_custom_node.hlsl",
                         "engines/unreal/AnisoLine_nodes.t3d", "engines/unreal/HOWTO.md"}},
                       {"use", "a Custom node's body, and the nodes as copy-paste text (HOWTO.md)"},
                       {"checked",
                        "the body compiled by glslangValidator's HLSL front end, wrapped as Unreal "
                        "wraps a Custom node, in the tests; not by Unreal: no Unreal here"}};
  std::string covers = "the line model from tables/diffuse.exr and tables/specular.exr";
  if (m.second_active() || m.isotropic_active())
    covers += "; not this material's second fiber or isotropic term (shaders/ do not either)";
  *entry = {{"written", true}, {"folders", folders}, {"covers", covers}};
  return files;
}

}  // namespace aniso
