// "Which s applies at this point" (docs/models.md §4), decided in one place for every consumer: the
// simulator, verify, the preview's CPU reference and the truth comparison. The caller gives
// what the point knows: the capture's mathematical topology s_math, and the material's map (the
// topology map h, or the map of s) sampled at the point's uv, when the material names one.
#pragma once
#include <algorithm>
#include <cmath>
#include <variant>

#include "models/fiber_model.h"
#include "models/material.h"
#include "models/material_maps.h"

namespace aniso {

// `map_value`: the map value m = 2h - 1 in [-1, 1] for a TopologyMapRef (as the capture reader
// samples it), s for an SMapRef; ignored otherwise.
inline double s_at(const Material& m, double s_math, double map_value) {
  struct Visit {
    double s_math, map_value;
    double operator()(const UniformS& u) const { return u.s; }
    double operator()(const MathematicalS&) const { return s_math; }
    double operator()(const TopologyMapRef& t) const {
      return topology_with_map(s_math, t.amplitude, map_value);
    }
    double operator()(const SMapRef&) const { return std::clamp(map_value, 0.0, 1.0); }
  };
  return std::visit(Visit{s_math, map_value}, m.topology);
}

// The same at a point with texture coordinates (u, v): a topology map's amplitude from the
// material's map of it (maps.amplitude) where it has one, else as above.
inline double s_at(const Material& m, double s_math, double map_value, double u, double v) {
  if (m.maps.amplitude && m.topology_as<TopologyMapRef>())
    return topology_with_map(s_math, map_lookup(*m.maps.amplitude, u, v, 0, m.maps.repeat),
                             map_value);
  return s_at(m, s_math, map_value);
}

// True when the material's topology needs a map sampled at the point (s_at's map_value).
inline bool needs_map(const Material& m) {
  return m.topology_as<TopologyMapRef>() != nullptr || m.topology_as<SMapRef>() != nullptr;
}

}  // namespace aniso
