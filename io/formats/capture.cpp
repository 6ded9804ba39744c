#include "io/formats/capture.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/color.h"
#include "core/texture.h"
#include "geometry/raycast.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/images/image_io.h"

namespace fs = std::filesystem;

namespace aniso {

using jsonu::Ctx;
using jsonu::json;

Intrinsics parse_camera(const json& j, const Ctx& c) {
  Intrinsics k;
  jsonu::check_keys(j, {"width", "height", "fx", "fy", "cx", "cy", "distortion"}, c);
  if (j.is_object() && j.contains("distortion")) {
    // OpenCV's k1 k2 p1 p2 k3 (a shorter list: the rest are zero). Rays cast at a mesh go
    // through the lens model (core/lens.h); buffers already say where each pixel looks.
    const json& d = j["distortion"];
    if (!d.is_array() || d.empty() || d.size() > 5)
      c.at("distortion").fail("expected 1 to 5 numbers: k1 k2 p1 p2 k3");
    for (size_t i = 0; i < d.size(); ++i) {
      k.distortion[i] = jsonu::num(d[i], c.at("distortion").idx(i));
      if (!std::isfinite(k.distortion[i]) || std::abs(k.distortion[i]) > 100)
        c.at("distortion").idx(i).fail("must be a finite number of magnitude below 100");
    }
  }
  const double w = jsonu::num(jsonu::need(j, "width", c), c.at("width"));
  const double h = jsonu::num(jsonu::need(j, "height", c), c.at("height"));
  if (w < 1 || h < 1 || w > 65536 || h > 65536 || w != std::floor(w) || h != std::floor(h))
    c.fail("width and height must be positive integers");
  k.width = static_cast<int>(w);
  k.height = static_cast<int>(h);
  k.fx = jsonu::num(jsonu::need(j, "fx", c), c.at("fx"));
  k.fy = jsonu::num(jsonu::need(j, "fy", c), c.at("fy"));
  k.cx = jsonu::num(jsonu::need(j, "cx", c), c.at("cx"));
  k.cy = jsonu::num(jsonu::need(j, "cy", c), c.at("cy"));
  if (!(k.fx > 0) || !(k.fy > 0)) c.fail("fx and fy must be positive");
  return k;
}

Light parse_light(const json& j, const Ctx& c) {
  Light l;
  const std::string type = jsonu::str(jsonu::need(j, "type", c), c.at("type"));
  if (type == "point")
    jsonu::check_keys(j, {"type", "position", "intensity", "attenuation", "position_sigma_m"}, c);
  else if (type == "spot")
    jsonu::check_keys(j,
                      {"type", "position", "intensity", "attenuation", "direction", "cutoff_deg",
                       "exponent", "position_sigma_m"},
                      c);
  else if (type == "directional")
    jsonu::check_keys(j, {"type", "direction", "irradiance"}, c);
  if (type == "point" || type == "spot") {
    l.type = type == "point" ? Light::Type::kPoint : Light::Type::kSpot;
    l.position = jsonu::vec3(jsonu::need(j, "position", c), c.at("position"));
    l.intensity = jsonu::rgb(jsonu::need(j, "intensity", c), c.at("intensity"));
    if (j.contains("attenuation")) {
      l.attenuation = jsonu::rgb(j["attenuation"], c.at("attenuation"));
      if (l.attenuation[0] < 0 || l.attenuation[1] < 0 || l.attenuation[2] < 0 ||
          l.attenuation[0] + l.attenuation[1] + l.attenuation[2] <= 0)
        c.at("attenuation").fail("coefficients must be non-negative and not all zero");
    }
    if (l.type == Light::Type::kSpot) {
      l.direction = jsonu::vec3(jsonu::need(j, "direction", c), c.at("direction"));
      l.cutoff_deg = jsonu::num(jsonu::need(j, "cutoff_deg", c), c.at("cutoff_deg"));
      l.exponent = jsonu::num_or(j, "exponent", 0.0, c);
      if (l.cutoff_deg <= 0 || l.cutoff_deg > 180) c.at("cutoff_deg").fail("must be in (0, 180]");
      if (length(l.direction) == 0) c.at("direction").fail("zero vector");
    }
    if (j.contains("position_sigma_m")) {
      const json& s = j["position_sigma_m"];
      const Ctx cs = c.at("position_sigma_m");
      if (s.is_number()) {
        const double v = jsonu::num(s, cs);
        l.position_sigma_m = {v, v, v};
      } else {
        l.position_sigma_m = jsonu::vec3(s, cs);
      }
      const Vec3& v = l.position_sigma_m;
      if (!(v.x >= 0 && v.y >= 0 && v.z >= 0 && std::isfinite(v.x + v.y + v.z)))
        cs.fail("must be a finite number of metres, 0 or more (one, or one per axis)");
    }
  } else if (type == "directional") {
    l.type = Light::Type::kDirectional;
    l.direction = jsonu::vec3(jsonu::need(j, "direction", c), c.at("direction"));
    if (length(l.direction) == 0) c.at("direction").fail("zero vector");
    l.intensity = jsonu::rgb(jsonu::need(j, "irradiance", c), c.at("irradiance"));
  } else {
    c.at("type").fail("unknown light type '" + type + "' (point, directional, spot)");
  }
  for (double v : l.intensity)
    if (v < 0) c.fail("negative light intensity");
  return l;
}

json camera_json(const Intrinsics& k) {
  json o{{"width", k.width}, {"height", k.height}, {"fx", k.fx},
         {"fy", k.fy},       {"cx", k.cx},         {"cy", k.cy}};
  if (k.distorted())
    o["distortion"] = json(std::vector<double>(k.distortion.begin(), k.distortion.end()));
  return o;
}

json light_json(const Light& l) {
  json jl;
  if (l.type == Light::Type::kDirectional) {
    jl = {{"type", "directional"},
          {"direction", jsonu::to_json(l.direction)},
          {"irradiance", jsonu::to_json(l.intensity)}};
  } else {
    jl = {{"type", l.type == Light::Type::kPoint ? "point" : "spot"},
          {"position", jsonu::to_json(l.position)},
          {"intensity", jsonu::to_json(l.intensity)},
          {"attenuation", jsonu::to_json(l.attenuation)}};
    if (l.type == Light::Type::kSpot) {
      jl["direction"] = jsonu::to_json(l.direction);
      jl["cutoff_deg"] = l.cutoff_deg;
      jl["exponent"] = l.exponent;
    }
    const Vec3& s = l.position_sigma_m;
    if (s.x > 0 || s.y > 0 || s.z > 0) jl["position_sigma_m"] = jsonu::to_json(s);
  }
  return jl;
}

namespace {

GeometrySpec parse_geometry(const json& j, const Ctx& c) {
  if (!j.is_object()) c.fail("expected an object");
  jsonu::check_keys(
      j, {"mesh", "position", "normal", "tangent", "mask", "uv", "topology", "fiber_field"}, c);
  GeometrySpec g;
  g.mesh = jsonu::str_or(j, "mesh", "", c);
  g.position = jsonu::str_or(j, "position", "", c);
  g.normal = jsonu::str_or(j, "normal", "", c);
  g.tangent = jsonu::str_or(j, "tangent", "", c);
  g.mask = jsonu::str_or(j, "mask", "", c);
  g.uv = jsonu::str_or(j, "uv", "", c);
  g.topology = jsonu::str_or(j, "topology", "", c);
  g.fiber_field = jsonu::str_or(j, "fiber_field", "", c);
  if (!g.fiber_field.empty() && g.fiber_field != "radial" && g.fiber_field != "circular" &&
      g.fiber_field != "meridian")
    c.at("fiber_field").fail("unknown value '" + g.fiber_field + "' (radial, circular, meridian)");
  if (g.mesh.empty()) {
    if (g.position.empty() || g.normal.empty() || g.tangent.empty())
      c.fail("needs either \"mesh\" or the buffers \"position\", \"normal\" and \"tangent\"");
  }
  return g;
}

Mat4 parse_pose(const json& j, const Ctx& c) {
  if (!j.is_array() || j.size() != 4) c.fail("expected a 4x4 row-major matrix");
  Mat4 m;
  for (int r = 0; r < 4; ++r) {
    if (!j[r].is_array() || j[r].size() != 4) c.idx(r).fail("expected a row of 4 numbers");
    for (int k = 0; k < 4; ++k) m(r, k) = jsonu::num(j[r][k], c.idx(r).idx(k));
  }
  // Rigid: orthonormal rotation and last row (0 0 0 1).
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double d = 0;
      for (int k = 0; k < 3; ++k) d += m(k, a) * m(k, b);
      if (std::abs(d - (a == b ? 1.0 : 0.0)) > 1e-4) c.fail("rotation part is not orthonormal");
    }
  if (m(3, 0) != 0 || m(3, 1) != 0 || m(3, 2) != 0 || m(3, 3) != 1)
    c.fail("last row must be 0 0 0 1");
  return m;
}

}  // namespace

// The "color" block: how integer codes decode to linear values (docs/formats.md).
ColorSpec parse_color(const json& col, const Ctx& c) {
  ColorSpec out;
  if (!col.is_object()) c.fail("expected an object");
  jsonu::check_keys(col, {"encoding", "black_level", "saturation"}, c);
  out.encoding_given = col.contains("encoding");
  if (col.contains("encoding")) {
    const json& e = col["encoding"];
    if (e.is_string()) {
      const std::string name = e.get<std::string>();
      if (name == "linear")
        out.encoding = ColorSpec::Encoding::kLinear;
      else if (name == "srgb")
        out.encoding = ColorSpec::Encoding::kSrgb;
      else
        c.at("encoding").fail("unknown encoding '" + name + "' (linear, srgb, {\"gamma\": g})");
    } else if (e.is_object() && e.contains("gamma")) {
      out.encoding = ColorSpec::Encoding::kGamma;
      out.gamma = jsonu::num(e["gamma"], c.at("encoding").at("gamma"));
      if (!(out.gamma > 0)) c.at("encoding").at("gamma").fail("must be positive");
    } else {
      c.at("encoding").fail("expected \"linear\", \"srgb\" or {\"gamma\": g}");
    }
  }
  out.black_level = jsonu::num_or(col, "black_level", 0.0, c);
  // Stored integer codes are scaled to [0, 1]: a black level outside it is a mistake.
  if (out.black_level < 0 || out.black_level >= 1)
    c.at("black_level").fail("must be in [0, 1) (a fraction of the largest code)");
  if (col.contains("saturation")) {
    out.saturation = jsonu::num(col["saturation"], c.at("saturation"));
    out.saturation_given = true;
  }
  return out;
}

namespace {

// One entry of "views"; the set's camera and geometry where the view gives none.
ViewSpec parse_view(const json& v, const Ctx& c, const CaptureSet& s) {
  if (!v.is_object()) c.fail("expected an object");
  jsonu::check_keys(
      v, {"image", "world_from_camera", "exposure", "lights", "camera", "geometry", "source"}, c);
  ViewSpec vs;
  vs.image = jsonu::str(jsonu::need(v, "image", c), c.at("image"));
  vs.world_from_camera =
      parse_pose(jsonu::need(v, "world_from_camera", c), c.at("world_from_camera"));
  vs.exposure = jsonu::num_or(v, "exposure", 1.0, c);
  if (vs.exposure < 0) c.at("exposure").fail("must be non-negative");
  vs.camera = v.contains("camera") ? parse_camera(v["camera"], c.at("camera")) : s.camera;
  if (v.contains("source")) {
    const json& src = v["source"];
    if (src.is_string()) {
      vs.source.push_back(src.get<std::string>());
    } else {
      if (!src.is_array()) c.at("source").fail("expected a file name or an array of them");
      for (size_t k = 0; k < src.size(); ++k)
        vs.source.push_back(jsonu::str(src[k], c.at("source").idx(k)));
    }
  }
  const json& lights = jsonu::need(v, "lights", c);
  if (!lights.is_array() || lights.empty()) c.at("lights").fail("a view needs at least one light");
  for (size_t k = 0; k < lights.size(); ++k)
    vs.lights.push_back(parse_light(lights[k], c.at("lights").idx(k)));
  if (v.contains("geometry")) {
    vs.geometry = parse_geometry(v["geometry"], c.at("geometry"));
  } else {
    if (s.geometry.empty())
      c.fail("no geometry: neither the view nor the set has a \"geometry\" block");
    vs.geometry = s.geometry;
  }
  return vs;
}

}  // namespace

CaptureSet read_capture(const std::string& path_in) {
  std::string file = path_in;
  if (fs::is_directory(path_in)) file = (fs::path(path_in) / "capture.json").string();
  if (!fs::exists(file)) throw Error(file + ": file not found");
  const json j = jsonu::parse_file(read_text_file(file), file);
  const Ctx root{file, ""};
  if (!j.is_object()) root.fail("expected a JSON object");
  const std::string format = jsonu::str(jsonu::need(j, "format", root), root.at("format"));
  if (format != "aniso-capture")
    root.at("format").fail("expected \"aniso-capture\", got \"" + format + "\"");
  const double version = jsonu::num(jsonu::need(j, "version", root), root.at("version"));
  if (version != 1)
    root.at("version").fail("unsupported version " + jsonu::json(version).dump() +
                            " (this reader knows 1)");

  jsonu::check_keys(j,
                    {"format", "version", "camera", "color", "ambient", "geometry", "views",
                     "truth", "topology_map", "generator"},
                    root);
  CaptureSet s;
  s.file = file;
  s.dir = parent_dir(file);
  s.camera = parse_camera(jsonu::need(j, "camera", root), root.at("camera"));
  if (j.contains("color")) s.color = parse_color(j["color"], root.at("color"));
  if (j.contains("ambient")) s.ambient = jsonu::rgb(j["ambient"], root.at("ambient"));
  if (j.contains("geometry")) s.geometry = parse_geometry(j["geometry"], root.at("geometry"));
  s.truth = jsonu::str_or(j, "truth", "", root);
  s.topology_map = jsonu::str_or(j, "topology_map", "", root);
  if (j.contains("generator")) s.provenance = j["generator"].dump();

  const json& views = jsonu::need(j, "views", root);
  if (!views.is_array() || views.empty())
    root.at("views").fail("expected a non-empty array of views");
  for (size_t i = 0; i < views.size(); ++i)
    s.views.push_back(parse_view(views[i], root.at("views").idx(i), s));
  return s;
}

std::vector<std::string> capture_input_files(const CaptureSet& s) {
  std::vector<std::string> f{s.file};
  auto add = [&](const std::string& rel) {
    if (!rel.empty()) f.push_back(join_path(s.dir, rel));
  };
  auto geo = [&](const GeometrySpec& g) {
    for (const auto* p : {&g.position, &g.normal, &g.tangent, &g.mask, &g.uv, &g.topology, &g.mesh})
      add(*p);
  };
  geo(s.geometry);
  for (const auto& v : s.views) {
    add(v.image);
    geo(v.geometry);
  }
  add(s.topology_map);
  add(s.truth);
  return f;
}

void write_capture_json(const CaptureSet& s, const std::string& path) {
  const auto& cam = camera_json;
  auto same = [](const Intrinsics& a, const Intrinsics& b) {
    return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
           a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
  };
  auto geo = [](const GeometrySpec& g) {
    json o = json::object();
    auto put = [&](const char* k, const std::string& v) {
      if (!v.empty()) o[k] = v;
    };
    put("mesh", g.mesh);
    put("position", g.position);
    put("normal", g.normal);
    put("tangent", g.tangent);
    put("mask", g.mask);
    put("uv", g.uv);
    put("topology", g.topology);
    put("fiber_field", g.fiber_field);
    return o;
  };
  json j;
  j["format"] = "aniso-capture";
  j["version"] = 1;
  j["camera"] = cam(s.camera);
  json color;
  switch (s.color.encoding) {
    case ColorSpec::Encoding::kLinear:
      color["encoding"] = "linear";
      break;
    case ColorSpec::Encoding::kSrgb:
      color["encoding"] = "srgb";
      break;
    case ColorSpec::Encoding::kGamma:
      color["encoding"] = json{{"gamma", s.color.gamma}};
      break;
  }
  if (s.color.black_level != 0) color["black_level"] = s.color.black_level;
  if (s.color.saturation_given) color["saturation"] = s.color.saturation;
  j["color"] = color;
  j["ambient"] = jsonu::to_json(s.ambient);
  if (!s.geometry.empty()) j["geometry"] = geo(s.geometry);
  json views = json::array();
  for (const auto& v : s.views) {
    json jv;
    jv["image"] = v.image;
    json pose = json::array();
    for (int r = 0; r < 4; ++r)
      pose.push_back({v.world_from_camera(r, 0), v.world_from_camera(r, 1),
                      v.world_from_camera(r, 2), v.world_from_camera(r, 3)});
    jv["world_from_camera"] = pose;
    jv["exposure"] = v.exposure;
    if (!same(v.camera, s.camera)) jv["camera"] = cam(v.camera);
    if (!v.source.empty()) jv["source"] = v.source;
    json lights = json::array();
    for (const auto& l : v.lights) lights.push_back(light_json(l));
    jv["lights"] = lights;
    if (!v.geometry.empty()) jv["geometry"] = geo(v.geometry);
    views.push_back(jv);
  }
  j["views"] = views;
  if (!s.truth.empty()) j["truth"] = s.truth;
  if (!s.topology_map.empty()) j["topology_map"] = s.topology_map;
  if (!s.provenance.empty()) j["generator"] = json::parse(s.provenance);
  write_text_file(path, j.dump(2) + "\n");
}

}  // namespace aniso
