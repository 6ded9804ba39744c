#include "io/formats/material_io.h"

#include <cmath>
#include <filesystem>
#include <memory>

#include "core/angles.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/images/image_io.h"
#include "models/params.h"

namespace aniso {

using jsonu::Ctx;
using jsonu::json;

namespace {

void check_bounds(const std::string& key, const RGB& v, const Ctx& c) {
  const ParamSpec& p = line_param(key);
  for (double x : v)
    if (x < p.lo || x > p.hi)
      c.fail("value " + json(x).dump() + " outside [" + json(p.lo).dump() + ", " +
             json(p.hi).dump() + "]");
}
double scalar(const json& j, const std::string& name, const std::string& key, double def,
              const Ctx& c) {
  if (!j.contains(name)) return def;
  const double x = jsonu::num(j[name], c.at(name));
  const ParamSpec& p = line_param(key);
  if (p.periodic) return wrap_fiber_deg(x);  // T -> -T symmetry: [0, 180)
  if (x < p.lo || x > p.hi)
    c.at(name).fail("value " + json(x).dump() + " outside [" + json(p.lo).dump() + ", " +
                    json(p.hi).dump() + "]");
  return x;
}

bool finite_json(const json& j) {
  if (j.is_number_float()) return std::isfinite(j.get<double>());
  if (j.is_array() || j.is_object()) {
    for (const auto& x : j)
      if (!finite_json(x)) return false;
  }
  return true;
}

// The optional terms of the line model (docs/models.md §3): isotropic lobe, second fiber.
void parse_optional_terms(const json& j, const Ctx& root, Material* mp) {
  Material& m = *mp;
  if (j.contains("isotropic")) {
    const Ctx c = root.at("isotropic");
    const json& b = j["isotropic"];
    if (!b.is_object()) c.fail("expected an object");
    jsonu::check_keys(b, {"kd", "ks", "n"}, c);
    m.has_isotropic = true;
    if (b.contains("kd")) m.iso_kd = jsonu::rgb(b["kd"], c.at("kd"));
    if (b.contains("ks")) m.iso_ks = jsonu::rgb(b["ks"], c.at("ks"));
    check_bounds("isotropic.kd", m.iso_kd, c.at("kd"));
    check_bounds("isotropic.ks", m.iso_ks, c.at("ks"));
    m.iso_n = scalar(b, "n", "isotropic.n", 20.0, c);
  }
  if (j.contains("second_fiber")) {
    const Ctx c = root.at("second_fiber");
    const json& b = j["second_fiber"];
    if (!b.is_object()) c.fail("expected an object");
    jsonu::check_keys(b, {"angle_deg", "weight"}, c);
    m.has_second_fiber = true;
    m.second_angle_deg =
        scalar(b, "angle_deg", "second_fiber.angle_deg", m.fiber_angle_deg + 90.0, c);
    m.second_weight = scalar(b, "weight", "second_fiber.weight", 0.5, c);
  }
}

// One topology source (docs/models.md §4), parsed into its type here and nowhere else.
void parse_topology(const json& j, const Ctx& root, Material* mp) {
  Material& m = *mp;
  if (j.contains("topology")) {
    // One topology source (docs/models.md §4), parsed into its type here and nowhere else.
    const Ctx c = root.at("topology");
    const json& b = j["topology"];
    if (!b.is_object()) c.fail("expected an object");
    jsonu::check_keys(b, {"s", "map", "amplitude", "mathematical", "s_map", "s_map_texels"}, c);
    const std::string math = jsonu::str_or(b, "mathematical", "none", c);
    MathTopology kind = MathTopology::kNone;
    if (math == "torus")
      kind = MathTopology::kTorus;
    else if (math == "sphere")
      kind = MathTopology::kSphere;
    else if (math != "none")
      c.at("mathematical")
          .fail("unknown value '" + math + "'" + did_you_mean(math, {"torus", "sphere", "none"}) +
                " (torus, sphere, none)");
    const int sources = b.contains("s") + b.contains("map") + b.contains("s_map");
    if (sources > 1) c.fail("give one topology source: \"s\", \"map\" or \"s_map\", not several");
    if (b.contains("s")) {
      if (kind != MathTopology::kNone)
        c.fail("\"s\" is one value for a flat sample; with \"mathematical\": \"" + math +
               "\" the capture's per-pixel topology applies (leave \"s\" out)");
      m.topology = UniformS{scalar(b, "s", "topology.s", 0.0, c)};  // bounds: models/params.h
    } else if (b.contains("map")) {
      TopologyMapRef t;
      t.file = jsonu::str(b["map"], c.at("map"));
      t.amplitude =
          scalar(b, "amplitude", "topology.amplitude", line_param("topology.amplitude").def, c);
      t.over = kind;
      m.topology = t;
    } else if (b.contains("s_map")) {
      if (kind != MathTopology::kNone)
        c.fail("a map of s (\"s_map\") stands alone: no \"mathematical\"");
      m.topology = SMapRef{jsonu::str(b["s_map"], c.at("s_map"))};
    } else if (kind != MathTopology::kNone) {
      m.topology = MathematicalS{kind};
    } else {
      c.fail(
          "needs \"s\", \"s_map\", or \"map\" with \"amplitude\", or \"mathematical\": \"torus\"");
    }
    if (b.contains("amplitude") && !b.contains("map"))
      c.at("amplitude").fail("belongs with \"map\"");
  } else if (m.fiber()) {
    root.at("topology").fail("the fiber model needs a topology block");
  }
}

// "maps" (docs/formats.md "Material maps"): the file names here; read_material loads the images.
void parse_maps(const json& j, const Ctx& root, Material* m) {
  if (!j.contains("maps")) return;
  const Ctx c = root.at("maps");
  const json& b = j["maps"];
  if (!b.is_object()) c.fail("expected an object");
  jsonu::check_keys(b, {"kd", "ks", "n", "fiber", "s", "amplitude", "wrap"}, c);
  MaterialMaps& mp = m->maps;
  mp.kd_file = jsonu::str_or(b, "kd", "", c);
  mp.ks_file = jsonu::str_or(b, "ks", "", c);
  mp.n_file = jsonu::str_or(b, "n", "", c);
  mp.fiber_file = jsonu::str_or(b, "fiber", "", c);
  if (b.contains("s")) {
    if (!m->fiber()) c.at("s").fail("a map of the topology s needs \"model\": \"fiber\"");
    m->topology = SMapRef{jsonu::str(b["s"], c.at("s"))};
  }
  if (b.contains("amplitude")) {
    if (!m->fiber() || !m->topology_as<TopologyMapRef>())
      c.at("amplitude")
          .fail(
              "a map of the topology amplitude needs \"model\": \"fiber\" and a topology map "
              "(\"topology\": {\"map\": ...})");
    mp.amplitude_file = jsonu::str(b["amplitude"], c.at("amplitude"));
  }
  const std::string wrap = jsonu::str_or(b, "wrap", "clamp", c);
  if (wrap != "clamp" && wrap != "repeat")
    c.at("wrap").fail("unknown value '" + wrap + "' (clamp, repeat)");
  mp.repeat = wrap == "repeat";
}

// A map the material names must be there: say so now, naming the material and the key. Returns
// its path.
std::string need_map_file(const std::string& path, const std::string& rel, const std::string& key) {
  const std::string f = join_path(parent_dir(path), rel);
  if (!std::filesystem::is_regular_file(f))
    throw Error(path + ": " + key + ": map file not found: " + f +
                " (paths in a material are relative to the material file)");
  return f;
}

// Loads one map named in the material: a float image with at least `channels` channels, finite,
// each value within the parameter's bounds (fiber: a unit-length doubled-angle vector, or near).
std::shared_ptr<const Image> load_map(const std::string& path, const std::string& rel,
                                      const std::string& key, int channels, const char* param) {
  if (rel.empty()) return nullptr;
  const std::string f = need_map_file(path, rel, "maps." + key);
  auto img = std::make_shared<Image>(read_image(f).image);
  if (img->channels < channels && !(channels == 3 && img->channels == 1))
    throw Error(path + ": maps." + key + ": " + f + " has " + std::to_string(img->channels) +
                " channel(s), needs " + std::to_string(channels));
  for (float v : img->px)
    if (!std::isfinite(v))
      throw Error(path + ": maps." + key + ": " + f + " holds a non-finite value");
  if (param) {
    const ParamSpec& p = line_param(param);
    for (float v : img->px)
      if (v < p.lo || v > p.hi)
        throw Error(path + ": maps." + key + ": " + f + ": value " + std::to_string(v) +
                    " outside [" + std::to_string(p.lo) + ", " + std::to_string(p.hi) + "]");
  }
  return img;
}

}  // namespace

Material material_from_json(const json& j, const std::string& file) {
  const Ctx root{file, ""};
  if (!j.is_object()) root.fail("expected a JSON object");
  const std::string format = jsonu::str(jsonu::need(j, "format", root), root.at("format"));
  if (format != "aniso-material")
    root.at("format").fail("expected \"aniso-material\", got \"" + format + "\"");
  const double version = jsonu::num(jsonu::need(j, "version", root), root.at("version"));
  if (version != 1) root.at("version").fail("unsupported version (this reader knows 1)");
  jsonu::check_keys(
      j,
      {"format", "version", "model", "kd", "ks", "n", "fiber_angle_deg", "ka", "isotropic",
       "second_fiber", "topology", "uncertainty", "fixed", "undetermined", "report", "maps",
       "maps_uncertainty", "previews", "written_by"},
      root);
  Material m;
  const std::string model = jsonu::str_or(j, "model", "line", root);
  if (model == "line")
    m.model = Model::kLine;
  else if (model == "fiber")
    m.model = Model::kFiber;
  else
    root.at("model").fail("unknown model '" + model + "'" + did_you_mean(model, {"line", "fiber"}) +
                          " (line, fiber)");
  m.kd = jsonu::rgb(jsonu::need(j, "kd", root), root.at("kd"));
  check_bounds("kd", m.kd, root.at("kd"));
  m.ks = jsonu::rgb(jsonu::need(j, "ks", root), root.at("ks"));
  check_bounds("ks", m.ks, root.at("ks"));
  jsonu::need(j, "n", root);
  m.n = scalar(j, "n", "n", 40.0, root);
  jsonu::need(j, "fiber_angle_deg", root);
  m.fiber_angle_deg = scalar(j, "fiber_angle_deg", "fiber_angle_deg", 0.0, root);
  if (j.contains("ka")) {
    m.ka = jsonu::rgb(j["ka"], root.at("ka"));
    check_bounds("ka", m.ka, root.at("ka"));
  }
  parse_optional_terms(j, root, &m);
  parse_topology(j, root, &m);
  parse_maps(j, root, &m);
  return m;
}

Material read_material(const std::string& path) {
  Material m = material_from_json(jsonu::parse_file(read_text_file(path), path), path);
  m.base_dir = parent_dir(path);
  if (const auto* t = m.topology_as<TopologyMapRef>()) need_map_file(path, t->file, "topology.map");
  if (const auto* t = m.topology_as<SMapRef>()) need_map_file(path, t->file, "topology.s_map");
  load_material_maps(path, &m);
  return m;
}

void load_material_maps(const std::string& path, Material* m) {
  MaterialMaps& mp = m->maps;
  mp.kd = load_map(path, mp.kd_file, "kd", 3, "kd");
  mp.ks = load_map(path, mp.ks_file, "ks", 3, "ks");
  mp.n = load_map(path, mp.n_file, "n", 1, "n");
  mp.fiber = load_map(path, mp.fiber_file, "fiber", 2, nullptr);
  mp.amplitude = load_map(path, mp.amplitude_file, "amplitude", 1, "topology.amplitude");
}

std::string named_map_file(const std::string& path, const std::string& block,
                           const std::string& key) {
  const json j = json::parse(read_text_file(path), nullptr, false);
  if (!j.is_object() || !j.contains(block) || !j[block].is_object()) return "";
  const json& b = j[block];
  if (!b.contains(key) || !b[key].is_string()) return "";
  return join_path(std::filesystem::path(path).parent_path().string(), b[key].get<std::string>());
}

std::vector<std::string> material_input_files(const Material& m, const std::string& path) {
  std::vector<std::string> f{path};
  if (const auto* t = m.topology_as<TopologyMapRef>()) f.push_back(join_path(m.base_dir, t->file));
  if (const auto* t = m.topology_as<SMapRef>()) f.push_back(join_path(m.base_dir, t->file));
  for (const auto* rel : {&m.maps.kd_file, &m.maps.ks_file, &m.maps.n_file, &m.maps.fiber_file,
                          &m.maps.amplitude_file})
    if (!rel->empty()) f.push_back(join_path(m.base_dir, *rel));
  return f;
}

void material_to_json(const Material& m, json* out) {
  json& j = *out;
  j["format"] = "aniso-material";
  j["version"] = 1;
  j["model"] = model_name(m.model);
  j["kd"] = jsonu::to_json(m.kd);
  j["ks"] = jsonu::to_json(m.ks);
  j["n"] = m.n;
  j["fiber_angle_deg"] = m.fiber_angle_deg;
  j["ka"] = jsonu::to_json(m.ka);
  if (m.has_isotropic)
    j["isotropic"] = {
        {"kd", jsonu::to_json(m.iso_kd)}, {"ks", jsonu::to_json(m.iso_ks)}, {"n", m.iso_n}};
  if (m.has_second_fiber)
    j["second_fiber"] = {{"angle_deg", m.second_angle_deg}, {"weight", m.second_weight}};
  if (m.fiber()) {
    jsonu::json t = jsonu::json::object();
    if (const auto* u = m.topology_as<UniformS>()) t["s"] = u->s;
    if (const auto* x = m.topology_as<TopologyMapRef>()) {
      t["map"] = x->file;
      t["amplitude"] = x->amplitude;
    }
    if (const auto* x = m.topology_as<SMapRef>()) t["s_map"] = x->file;
    t["mathematical"] = math_topology_name(m.mathematical());
    j["topology"] = t;
  }
  const MaterialMaps& mp = m.maps;
  if (!mp.kd_file.empty() || !mp.ks_file.empty() || !mp.n_file.empty() || !mp.fiber_file.empty() ||
      !mp.amplitude_file.empty()) {
    json maps = json::object();
    if (!mp.kd_file.empty()) maps["kd"] = mp.kd_file;
    if (!mp.ks_file.empty()) maps["ks"] = mp.ks_file;
    if (!mp.n_file.empty()) maps["n"] = mp.n_file;
    if (!mp.fiber_file.empty()) maps["fiber"] = mp.fiber_file;
    if (!mp.amplitude_file.empty()) maps["amplitude"] = mp.amplitude_file;
    maps["wrap"] = mp.repeat ? "repeat" : "clamp";
    j["maps"] = maps;
  }
}

void write_json_file(const std::string& path, const json& j) {
  if (!finite_json(j)) throw Error(path + ": refusing to write a non-finite number");
  const std::string stamp = json_stamp(path);  // who wrote it (io/files/files.h)
  std::string text = j.dump(2, ' ', false, json::error_handler_t::replace);
  if (!stamp.empty() && j.is_object() && !j.empty() && !j.contains("written_by"))
    text.insert(text.size() - 2, ",\n  \"written_by\": " + json(stamp).dump());  // the last key
  write_text_file(path, text + "\n");
}

}  // namespace aniso
