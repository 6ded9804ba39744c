// One description of every model parameter: name (the material-file key), symbol, size, bounds,
// default, unit, whether it is periodic, and whether the fitter works on its logarithm. The
// fitter, the material reader, the CLI (`aniso params`), the bake and the docs all read this
// table; nothing else states a bound.
#pragma once
#include <cmath>
#include <string>
#include <string_view>

#include "core/error.h"

namespace aniso {

struct ParamSpec {
  std::string_view key;     // material-file key, dotted for nested blocks
  std::string_view symbol;  // docs/models.md symbol
  int dims;                 // 3 = RGB, 1 = scalar
  double lo, hi, def;       // bounds and default
  std::string_view unit;
  bool periodic;  // fiber angles live in [0, 180) degrees (docs/models.md §1)
  bool fit_log;   // fitted as log(value) (docs/models.md §6: log n, not n)
  std::string_view doc;
  // The standard deviation of a value spread evenly over the bounds: what the bounds alone know
  // of it (a sigma above this is no measurement).
  double spread() const { return (hi - lo) / std::sqrt(12.0); }
};

// Line-lighting model, docs/models.md §3. Exponent bounds: n = 1 keeps x^n differentiable at x = 0;
// n = 1e4 is the sharpest lobe the bake tables resolve at their largest size.
inline constexpr ParamSpec kLineParams[] = {
    {"kd", "k_d", 3, 0.0, 100.0, 0.2, "", false, false, "diffuse coefficient, RGB"},
    {"ks", "k_s", 3, 0.0, 100.0, 0.5, "", false, false, "specular coefficient, RGB (or grey)"},
    {"n", "n", 1, 1.0, 1.0e4, 40.0, "", false, true, "specular exponent (fitted as log n)"},
    {"fiber_angle_deg", "psi", 1, 0.0, 180.0, 0.0, "deg", true, false,
     "fiber direction about N from the reference tangent U, toward N x U"},
    {"ka", "k_a", 3, 0.0, 100.0, 0.0, "", false, false, "ambient coefficient, RGB"},
    {"isotropic.kd", "k_d,iso", 3, 0.0, 100.0, 0.0, "", false, false,
     "isotropic diffuse (Lambert) coefficient"},
    {"isotropic.ks", "k_s,iso", 3, 0.0, 100.0, 0.0, "", false, false,
     "isotropic specular (Blinn-Phong) coefficient"},
    {"isotropic.n", "n_iso", 1, 1.0, 1.0e4, 20.0, "", false, true, "Blinn-Phong exponent"},
    {"second_fiber.angle_deg", "psi_2", 1, 0.0, 180.0, 90.0, "deg", true, false,
     "second fiber direction (woven cloth); default psi + 90"},
    {"second_fiber.weight", "w", 1, 0.0, 1.0, 0.5, "", false, false,
     "weight of the first lobe; the second gets 1 - w"},
};

// Fiber model, docs/models.md §4: the line model's parameters plus the topology.
inline constexpr ParamSpec kFiberParams[] = {
    {"topology.s", "s", 1, 0.0, 1.0, 0.0, "", false, false,
     "topology: climbing angle 60 deg * s; s = 1 looks like s = 0 (flat samples)"},
    {"topology.amplitude", "A", 1, -2.0, 2.0, 0.25, "", false, false,
     "topology-map amplitude added to the height 2 sin(theta_math) (Hast: 0.25)"},
};

// The entry for `key`; an unknown key is a programming error and throws (never k_d's bounds).
inline const ParamSpec& line_param(std::string_view key) {
  for (const auto& p : kLineParams)
    if (p.key == key) return p;
  for (const auto& p : kFiberParams)
    if (p.key == key) return p;
  throw Error("internal: no parameter '" + std::string(key) + "' in models/params.h");
}

}  // namespace aniso
