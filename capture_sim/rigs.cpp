// The simulator's rigs (where the camera and the lights stand, view by view) and the camera that
// frames a sample: capture_sim/sim.h.
#include <cmath>

#include "capture_sim/sim.h"
#include "core/angles.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/material_io.h"

namespace aniso {

namespace {

constexpr double kGoldenAngle = 2.39996322972865332;  // pi (3 - sqrt 5)

Vec3 on_sphere(double polar_deg, double azimuth_rad, double r) {
  const double t = deg_to_rad(polar_deg);
  return {r * std::sin(t) * std::cos(azimuth_rad), r * std::sin(t) * std::sin(azimuth_rad),
          r * std::cos(t)};
}

Light point_light(const Vec3& pos, double distance) {
  Light l;
  l.type = Light::Type::kPoint;
  l.position = pos;
  const double i0 = distance * distance;  // irradiance about 1 at the sample
  l.intensity = {i0, i0, i0};
  return l;
}

}  // namespace

std::vector<RigView> rig_fixed_camera(int views, double camera_polar_deg, double distance) {
  if (views < 1) throw Error("rig: --views must be at least 1");
  std::vector<RigView> rig;
  const Vec3 eye = on_sphere(camera_polar_deg, -M_PI / 2, distance);
  for (int i = 0; i < views; ++i) {
    RigView v;
    v.world_from_camera = look_at(eye, {0, 0, 0}, {0, 0, 1});
    // Polar angle 10..70 degrees, uniform in cos over the band; golden-angle azimuths.
    const double f = (i + 0.5) / views;
    const double c =
        std::cos(deg_to_rad(10.0)) + f * (std::cos(deg_to_rad(70.0)) - std::cos(deg_to_rad(10.0)));
    const double polar = rad_to_deg(std::acos(c));
    v.lights.push_back(point_light(on_sphere(polar, i * kGoldenAngle, distance), distance));
    rig.push_back(v);
  }
  return rig;
}

std::vector<RigView> rig_orbit(int views, double distance) {
  if (views < 1) throw Error("rig: --views must be at least 1");
  std::vector<RigView> rig;
  for (int i = 0; i < views; ++i) {
    const double f = (i + 0.5) / views;
    RigView v;
    const Vec3 eye = on_sphere(20 + 45 * f, -M_PI / 2 + i * kGoldenAngle, distance);
    v.world_from_camera = look_at(eye, {0, 0, 0}, {0, 0, 1});
    v.lights.push_back(
        point_light(on_sphere(60 - 45 * f, M_PI / 3 + i * 2 * kGoldenAngle, distance), distance));
    rig.push_back(v);
  }
  return rig;
}

std::vector<RigView> rig_from_file(const std::string& path) {
  using jsonu::json;
  const json j = jsonu::parse_file(read_text_file(path), path);
  const jsonu::Ctx root{path, ""};
  const json& views = jsonu::need(j, "views", root);
  if (!views.is_array() || views.empty()) root.at("views").fail("expected a non-empty array");
  std::vector<RigView> rig;
  for (size_t i = 0; i < views.size(); ++i) {
    const jsonu::Ctx c = root.at("views").idx(i);
    RigView v;
    const Vec3 eye = jsonu::vec3(jsonu::need(views[i], "camera", c), c.at("camera"));
    const Vec3 target = views[i].contains("target")
                            ? jsonu::vec3(views[i]["target"], c.at("target"))
                            : Vec3{0, 0, 0};
    v.world_from_camera = look_at(eye, target, {0, 0, 1});
    const json& lights = jsonu::need(views[i], "lights", c);
    if (!lights.is_array() || lights.empty()) c.at("lights").fail("expected a non-empty array");
    for (size_t k = 0; k < lights.size(); ++k)
      v.lights.push_back(parse_light(lights[k], c.at("lights").idx(k)));
    rig.push_back(v);
  }
  return rig;
}

Intrinsics frame_camera(int width, int height, double radius, double distance) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  const double half =
      std::atan(1.15 * radius / std::sqrt(std::max(distance * distance - radius * radius, 1e-6)));
  k.fx = k.fy = 0.5 * std::min(width, height) / std::tan(half);
  k.cx = 0.5 * (width - 1);
  k.cy = 0.5 * (height - 1);
  return k;
}

}  // namespace aniso
