#include "datasets_synth/presets.h"

#include <cmath>
#include <random>

#include "core/error.h"
#include "io/files.h"

namespace aniso {

const std::vector<std::pair<std::string, std::string>>& preset_list() {
  static const std::vector<std::pair<std::string, std::string>> list = {
      {"brushed-metal", "flat sample, scratches at 30 deg, fixed camera, light over the hemisphere"},
      {"satin-ball", "sphere with pole-to-pole (meridian) fibers (Heidrich & Seidel fig. 3)"},
      {"cd", "disc with circular grooves (Heidrich & Seidel fig. 1, centre)"},
      {"radial-disc", "disc with radial fibers (Heidrich & Seidel fig. 1, right)"},
      {"woven-cloth", "flat sample with two perpendicular fiber directions (seed 000 §4)"},
      {"random", "flat sample with a random line-model material drawn from --seed"},
  };
  return list;
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
  constexpr double kDistance = 4.0;
  double radius = 1.0, camera_polar = 35.0;
  bool orbit = false;
  Material& m = o.truth;
  if (name == "brushed-metal") {
    o.shape = "flat";
    radius = std::sqrt(2.0);
    m.kd = {0.20, 0.15, 0.10};
    m.ks = {0.60, 0.60, 0.60};
    m.n = 40.0;
    m.fiber_angle_deg = 30.0;
  } else if (name == "satin-ball") {
    o.shape = "sphere";
    o.fiber_field = "meridian";
    camera_polar = 60.0;
    m.kd = {0.30, 0.04, 0.08};
    m.ks = {0.45, 0.40, 0.40};
    m.n = 25.0;
    m.fiber_angle_deg = 0.0;
  } else if (name == "cd") {
    o.shape = "disc";
    o.fiber_field = "circular";
    m.kd = {0.05, 0.05, 0.06};
    m.ks = {0.80, 0.80, 0.80};
    m.n = 120.0;
    m.fiber_angle_deg = 0.0;
  } else if (name == "radial-disc") {
    o.shape = "disc";
    o.fiber_field = "radial";
    m.kd = {0.10, 0.12, 0.15};
    m.ks = {0.50, 0.50, 0.50};
    m.n = 60.0;
    m.fiber_angle_deg = 0.0;
  } else if (name == "woven-cloth") {
    o.shape = "flat";
    radius = std::sqrt(2.0);
    m.kd = {0.30, 0.10, 0.12};
    m.ks = {0.35, 0.30, 0.30};
    m.n = 12.0;
    m.fiber_angle_deg = 10.0;
    m.has_second_fiber = true;
    m.second_angle_deg = 100.0;
    m.second_weight = 0.65;
  } else if (name == "random") {
    o.shape = "flat";
    radius = std::sqrt(2.0);
    m = random_material(po.seed);
  } else {
    std::string list;
    for (const auto& p : preset_list()) list += (list.empty() ? "" : ", ") + p.first;
    throw Error("synth: unknown preset '" + name + "' (" + list + ")");
  }
  o.camera = frame_camera(po.width, po.height, radius, kDistance);
  if (po.rig == "orbit" || (po.rig.empty() && orbit))
    o.rig = rig_orbit(po.views, kDistance);
  else if (po.rig.empty() || po.rig == "fixed-camera")
    o.rig = rig_fixed_camera(po.views, camera_polar, kDistance);
  else if (lower_ext(po.rig) == ".json")
    o.rig = rig_from_file(po.rig);
  else
    throw Error("synth: --rig must be fixed-camera, orbit or a rig .json file (got '" + po.rig + "')");
  return o;
}

}  // namespace aniso
