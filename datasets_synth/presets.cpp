#include "datasets_synth/presets.h"

#include <cmath>
#include <random>

#include "core/error.h"
#include "io/files/files.h"
#include "io/images/image_io.h"

namespace aniso {

const std::vector<std::pair<std::string, std::string>>& preset_list() {
  static const std::vector<std::pair<std::string, std::string>> list = {
      {"brushed-metal",
       "flat sample, scratches at 30 deg, fixed camera, light over the hemisphere"},
      {"satin-ball", "sphere with pole-to-pole (meridian) fibers (Heidrich & Seidel fig. 3)"},
      {"cd", "disc with circular grooves (Heidrich & Seidel fig. 1, centre)"},
      {"radial-disc", "disc with radial fibers (Heidrich & Seidel fig. 1, right)"},
      {"woven-cloth", "flat sample with two perpendicular fiber directions (Heidrich & Seidel §4)"},
      {"random", "flat sample with a random line-model material drawn from --seed"},
      {"swirl-plate",
       "flat sample whose material varies (maps): brushed in circles around its centre, k_d from "
       "copper on the left to steel on the right (for fit --maps)"},
      {"woven-patch",
       "flat sample woven in a checker of warp and weft blocks (maps): warp along u, red, n = 30; "
       "weft along v, blue, n = 12 (for fit --maps)"},
      {"cd-maps",
       "disc with circular grooves whose material varies with the radius (maps): a clear hub, "
       "the mirror-like data area, a plastic rim (for fit --maps)"},
      {"silk-torus",
       "fiber model: silk wound around a torus (R = 1, r = 0.6), mathematical topology + topology "
       "map "
       "(Hast's test object)"},
      {"fiber-flat", "fiber model: flat sample with topology value --topology-s"},
      {"satin-sphere-fiber",
       "fiber model: sphere with meridian fibers that climb toward the poles"},
      {"fiber-flat-map",
       "fiber model: flat sample whose topology varies over it (an 8x8 map of s in [0.15, 0.85])"},
  };
  return list;
}

Image procedural_topology_map(int size, uint64_t seed) {
  // Three octaves of bilinear value noise on tileable lattices (8, 16, 32 cells), normalised.
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Image img(size, size, 1);
  double amp = 1.0;
  for (int cells : {8, 16, 32}) {
    std::vector<double> lattice(static_cast<size_t>(cells) * cells);
    for (double& v : lattice) v = u(rng);
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const double fx = double(x) / size * cells, fy = double(y) / size * cells;
        const int x0 = int(fx), y0 = int(fy);
        const double tx = fx - x0, ty = fy - y0;
        const double sx = tx * tx * (3 - 2 * tx), sy = ty * ty * (3 - 2 * ty);
        auto L = [&](int i, int j) {
          return lattice[static_cast<size_t>(j % cells) * cells + (i % cells)];
        };
        img.at(x, y, 0) += static_cast<float>(
            amp * ((1 - sx) * (1 - sy) * L(x0, y0) + sx * (1 - sy) * L(x0 + 1, y0) +
                   (1 - sx) * sy * L(x0, y0 + 1) + sx * sy * L(x0 + 1, y0 + 1)));
      }
    amp *= 0.5;
  }
  float lo = 1e9f, hi = -1e9f;
  for (float v : img.px) lo = std::min(lo, v), hi = std::max(hi, v);
  for (float& v : img.px) v = (v - lo) / std::max(hi - lo, 1e-6f);
  return img;
}

Material random_material(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Material m;
  const double grey_kd = 0.05 + 0.4 * u(rng);
  for (int k = 0; k < 3; ++k) m.kd[k] = grey_kd * (0.5 + u(rng));
  const double ks = 0.1 + 0.8 * u(rng);
  m.ks = {ks, ks, ks};
  m.n = std::exp(std::log(4.0) + u(rng) * (std::log(400.0) - std::log(4.0)));
  m.fiber_angle_deg = 180.0 * u(rng);
  return m;
}

namespace {

// One texel of a preset's maps: the material at its centre.
struct TexelTruth {
  double psi = 0;  // radians
  RGB kd{0, 0, 0};
  double ks = 0, n = 0;
};
struct WhichMaps {
  bool fiber, kd, ks, n;
};

// A preset's maps (size x size), each that `which` names, from `at(u, v)` at the texel centres.
template <class At>
MaterialMaps preset_maps(int size, WhichMaps which, At at) {
  auto fiber = std::make_shared<Image>(size, size, 2);
  auto kd = std::make_shared<Image>(size, size, 3);
  auto ks = std::make_shared<Image>(size, size, 1);
  auto n = std::make_shared<Image>(size, size, 1);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const TexelTruth t = at((x + 0.5) / size, (y + 0.5) / size);
      fiber->at(x, y, 0) = static_cast<float>(std::cos(2 * t.psi));  // the doubled angle
      fiber->at(x, y, 1) = static_cast<float>(std::sin(2 * t.psi));
      for (int c = 0; c < 3; ++c) kd->at(x, y, c) = static_cast<float>(t.kd[c]);
      ks->at(x, y, 0) = static_cast<float>(t.ks);
      n->at(x, y, 0) = static_cast<float>(t.n);
    }
  MaterialMaps mp;
  if (which.fiber) mp.fiber = fiber;
  if (which.kd) mp.kd = kd;
  if (which.ks) mp.ks = ks;
  if (which.n) mp.n = n;
  return mp;
}

// The swirl plate's maps: psi turns around the centre (circular brushing), k_d goes from copper
// (u = 0) to steel (u = 1).
MaterialMaps swirl_maps(int size) {
  return preset_maps(size, {true, true, false, false}, [](double u, double v) {
    const RGB copper{0.30, 0.15, 0.08}, steel{0.10, 0.11, 0.13};
    TexelTruth t;
    t.psi = std::atan2(v - 0.5, u - 0.5) + M_PI / 2;
    for (int c = 0; c < 3; ++c) t.kd[c] = copper[c] + (steel[c] - copper[c]) * u;
    return t;
  });
}

// The woven patch's maps: a 4 x 4 checker of warp blocks (psi 0, along u) and weft blocks
// (psi 90), each with its own yarn colour and sharpness.
MaterialMaps woven_maps(int size) {
  return preset_maps(size, {true, true, false, true}, [](double u, double v) {
    const bool warp = (static_cast<int>(4 * u) + static_cast<int>(4 * v)) % 2 == 0;
    TexelTruth t;
    t.psi = warp ? 0 : M_PI / 2;
    t.kd = warp ? RGB{0.35, 0.10, 0.10} : RGB{0.10, 0.12, 0.30};
    t.n = warp ? 30 : 12;
    return t;
  });
}

// A CD's maps over the disc's uv, by the radius r = 2 |uv - 1/2|: the clear hub (r < 0.3: grey,
// dull), the data area (0.3..0.95: dark, mirror-like, n = 120) and the rim. The grooves follow
// the disc's circular tangent (psi = 0 everywhere: no fiber map).
MaterialMaps cd_maps(int size) {
  return preset_maps(size, {false, true, true, true}, [](double u, double v) {
    const double r = 2 * std::hypot(u - 0.5, v - 0.5);
    const int zone = r < 0.3 ? 0 : r < 0.95 ? 1 : 2;
    const RGB kds[3] = {{0.25, 0.25, 0.27}, {0.04, 0.04, 0.05}, {0.12, 0.12, 0.14}};
    const double kss[3] = {0.15, 0.80, 0.35}, ns[3] = {6, 120, 15};
    TexelTruth t;
    t.kd = kds[zone];
    t.ks = kss[zone];
    t.n = ns[zone];
    return t;
  });
}

// Where the camera stands for a preset's object.
struct Framing {
  double radius = 1.0, camera_polar = 35.0;
  bool orbit = false;
};

// A line-model material, and the flat sample most presets show.
void line_material(Material* m, RGB kd, RGB ks, double n, double psi_deg) {
  m->kd = kd;
  m->ks = ks;
  m->n = n;
  m->fiber_angle_deg = psi_deg;
}
void flat_sample(SimOptions* o, Framing* fr) {
  o->shape = "flat";
  fr->radius = std::sqrt(2.0);
}

// The line-model presets: object, fiber field and material. False for other names.
bool line_preset(const std::string& name, const PresetOptions& po, SimOptions* o, Framing* fr) {
  Material& m = o->truth;
  if (name == "brushed-metal") {
    flat_sample(o, fr);
    line_material(&m, {0.20, 0.15, 0.10}, {0.60, 0.60, 0.60}, 40.0, 30.0);
  } else if (name == "satin-ball") {
    o->shape = "sphere";
    o->fiber_field = "meridian";
    fr->camera_polar = 60.0;
    line_material(&m, {0.30, 0.04, 0.08}, {0.45, 0.40, 0.40}, 25.0, 0.0);
  } else if (name == "cd" || name == "cd-maps") {
    o->shape = "disc";
    o->fiber_field = "circular";
    line_material(&m, {0.05, 0.05, 0.06}, {0.80, 0.80, 0.80}, 120.0, 0.0);
    if (name == "cd-maps") m.maps = cd_maps(64);
  } else if (name == "radial-disc") {
    o->shape = "disc";
    o->fiber_field = "radial";
    line_material(&m, {0.10, 0.12, 0.15}, {0.50, 0.50, 0.50}, 60.0, 0.0);
  } else if (name == "woven-cloth") {
    flat_sample(o, fr);
    line_material(&m, {0.30, 0.10, 0.12}, {0.35, 0.30, 0.30}, 12.0, 10.0);
    m.has_second_fiber = true;
    m.second_angle_deg = 100.0;
    m.second_weight = 0.65;
  } else if (name == "swirl-plate") {
    flat_sample(o, fr);
    line_material(&m, {0.20, 0.13, 0.105}, {0.60, 0.60, 0.60}, 40.0, 90.0);  // the maps' means
    m.maps = swirl_maps(64);
  } else if (name == "woven-patch") {
    flat_sample(o, fr);
    line_material(&m, {0.225, 0.11, 0.20}, {0.40, 0.40, 0.40}, 21.0, 0.0);  // the maps' means
    m.maps = woven_maps(64);
  } else if (name == "random") {
    flat_sample(o, fr);
    m = random_material(po.seed);
  } else {
    return false;
  }
  return true;
}

// The fiber-model presets: object, material and topology source. False for other names.
bool fiber_preset(const std::string& name, const PresetOptions& po, SimOptions* o, Framing* fr) {
  Material& m = o->truth;
  if (name == "silk-torus") {
    o->shape = "torus";
    o->shape_options.torus_R = 1.0;
    o->shape_options.torus_r = 0.6;  // outside 4x longer than inside: fibers climb twice (Hast)
    fr->radius = 1.6;
    fr->camera_polar = 40.0;
    m.model = Model::kFiber;
    m.kd = {0.30, 0.22, 0.06};
    m.ks = {0.55, 0.50, 0.35};
    m.n = 30.0;
    m.fiber_angle_deg = 90.0;  // wound around the tube: perpendicular to dP/du (toroidal)
    // The map's file is named by the capture set that stores it (capture_sim).
    m.topology = TopologyMapRef{"", po.topology_amplitude, MathTopology::kTorus};
    o->mathematical_topology = MathTopology::kTorus;
    if (po.topology_map_file.empty()) {
      o->topology_map = procedural_topology_map(256, po.seed);
    } else {
      o->topology_map = read_image(po.topology_map_file).image;
      if (o->topology_map.channels > 1) {  // first channel only
        Image first(o->topology_map.width, o->topology_map.height, 1);
        for (size_t p = 0; p < first.px.size(); ++p)
          first.px[p] = o->topology_map.px[p * o->topology_map.channels];
        o->topology_map = first;
      }
    }
  } else if (name == "fiber-flat" || name == "fiber-flat-map") {
    // One satin material; the topology is one value of s, or a map of s over the sample.
    o->shape = "flat";
    fr->radius = std::sqrt(2.0);
    m.model = Model::kFiber;
    m.kd = {0.25, 0.18, 0.12};
    m.ks = {0.50, 0.50, 0.50};
    m.n = 40.0;
    m.fiber_angle_deg = 30.0;
    if (po.topology_s < 0 || po.topology_s > 1)
      throw Error("synth: --topology-s must be in [0, 1]");
    m.topology = UniformS{po.topology_s};
    if (name == "fiber-flat-map") {
      m.topology = SMapRef{};  // named by the capture set that stores it
      o->s_map = procedural_topology_map(8, po.seed);
      for (float& v : o->s_map.px) v = 0.15f + 0.7f * v;
    }
  } else if (name == "satin-sphere-fiber") {
    o->shape = "sphere";
    o->fiber_field = "meridian";
    fr->camera_polar = 60.0;
    m.model = Model::kFiber;
    m.kd = {0.30, 0.04, 0.08};
    m.ks = {0.45, 0.40, 0.40};
    m.n = 25.0;
    m.fiber_angle_deg = 0.0;
    m.topology = MathematicalS{MathTopology::kSphere};
    o->mathematical_topology = MathTopology::kSphere;
  } else {
    return false;
  }
  return true;
}

}  // namespace

SimOptions make_preset(const std::string& name, const PresetOptions& po) {
  if (po.views < 1) throw Error("synth: --views must be at least 1");
  if (po.width < 8 || po.height < 8 || po.width > 8192 || po.height > 8192)
    throw Error("synth: --size must be between 8x8 and 8192x8192");
  SimOptions o;
  o.preset = name;
  o.seed = po.seed;
  o.progress = po.progress;
  o.sensor.read_noise = po.noise;
  o.sensor.shot_photons = po.shot_photons;
  o.sensor.bits = po.bits;
  o.sensor.encoding = po.encoding;
  if (po.saturation < 0)
    throw Error("synth: --saturation must be positive (a fraction of the white level)");
  if (po.saturation > 0) o.sensor.saturation = po.saturation;
  constexpr double kDistance = 4.0;
  Framing fr;
  if (!line_preset(name, po, &o, &fr) && !fiber_preset(name, po, &o, &fr)) {
    std::string list;
    for (const auto& p : preset_list()) list += (list.empty() ? "" : ", ") + p.first;
    throw Error("synth: unknown preset '" + name + "' (" + list + ")");
  }
  o.camera = frame_camera(po.width, po.height, fr.radius, kDistance);
  if (po.rig == "orbit" || (po.rig.empty() && fr.orbit))
    o.rig = rig_orbit(po.views, kDistance);
  else if (po.rig.empty() || po.rig == "fixed-camera")
    o.rig = rig_fixed_camera(po.views, fr.camera_polar, kDistance);
  else if (lower_ext(po.rig) == ".json")
    o.rig = rig_from_file(po.rig);
  else
    throw Error("synth: --rig must be fixed-camera, orbit or a rig .json file (got '" + po.rig +
                "')");
  return o;
}

}  // namespace aniso
