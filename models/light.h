// The lights of the forward model (docs/models.md §2, docs/formats.md "Lights"): point, directional
// and spot lights, and the light a surface point receives from each. Shared by the simulator, the
// fitter, verify and the capture reader.
#pragma once
#include <cmath>
#include <limits>

#include "core/angles.h"
#include "core/vec.h"
#include "models/material.h"

namespace aniso {

struct Light {
  enum class Type { kPoint, kDirectional, kSpot };
  Type type = Type::kPoint;
  Vec3 position{0, 0, 1};
  Vec3 direction{0, 0, 1};  // directional: toward the light; spot: the beam's direction
  RGB intensity{1, 1, 1};   // point/spot: I0; directional: irradiance E0
  RGB attenuation{0, 0, 1};
  double cutoff_deg = 90.0;
  double exponent = 0.0;
  // How well a point or spot light's position is known, one standard deviation per world axis in
  // metres (a photo shoot's lamps, as found from the board's paper); 0: not stated (the light is
  // taken as exact). Not part of the forward model.
  Vec3 position_sigma_m{0, 0, 0};
};

// A point light whose irradiance falls as the inverse square and nothing else: what the board's
// paper and the sample's highlight can place (photo/lamps, fit/lamps).
inline bool inverse_square_point(const Light& l) {
  return l.type == Light::Type::kPoint && l.attenuation[0] == 0 && l.attenuation[1] == 0 &&
         l.attenuation[2] == 1;
}

// The light at surface point x (docs/models.md §2): unit direction toward the light, the irradiance
// scale E (RGB) and the distance (infinity for a directional light). False when it delivers
// nothing there (outside a spot's cone, zero intensity).
inline bool light_at(const Light& light, const Vec3& x, Vec3* L, RGB* E, double* dist) {
  if (light.type == Light::Type::kDirectional) {
    *L = normalize(light.direction);
    *E = light.intensity;
    *dist = std::numeric_limits<double>::infinity();
  } else {
    const Vec3 d = light.position - x;
    const double r = length(d);
    if (!(r > 0.0)) return false;
    *L = d / r;
    *dist = r;
    const double att =
        light.attenuation[0] + light.attenuation[1] * r + light.attenuation[2] * r * r;
    if (!(att > 0.0)) return false;
    double f = 1.0 / att;
    if (light.type == Light::Type::kSpot) {
      const double c = -dot(*L, normalize(light.direction));
      if (c < std::cos(deg_to_rad(light.cutoff_deg)) || c <= 0.0) return false;
      f *= std::pow(c, light.exponent);
    }
    *E = {light.intensity[0] * f, light.intensity[1] * f, light.intensity[2] * f};
  }
  return (*E)[0] > 0 || (*E)[1] > 0 || (*E)[2] > 0;
}

}  // namespace aniso
