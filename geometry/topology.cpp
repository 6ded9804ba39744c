#include "geometry/topology.h"

#include <algorithm>
#include <cmath>

#include "models/fiber_model.h"

namespace aniso {

double mathematical_topology_at(MathTopology kind, const Vec3& P, const ShapeOptions& shape) {
  if (kind == MathTopology::kTorus) {
    const double rho = std::sqrt(P.x * P.x + P.y * P.y);
    return torus_mathematical_s(shape.torus_R, shape.torus_r, std::atan2(P.z, rho - shape.torus_R));
  }
  if (kind == MathTopology::kSphere) {
    // Meridian fibers are compressed by 1/sin(polar angle) away from the equator; the same
    // in-cycle rule as the torus: c' = c / 2^floor(log2 c), theta = acos(1/c').
    const double sin_polar = std::sqrt(P.x * P.x + P.y * P.y) / std::max(length(P), 1e-12);
    // Closer to the pole than this the compression is unbounded: the row is close packed.
    constexpr double kPoleSin = 1e-6;
    const double c = 1.0 / std::max(sin_polar, kPoleSin);
    const double cp = c / std::pow(2.0, std::floor(std::log2(c)));
    return std::acos(1.0 / cp) / kMaxClimbRad;
  }
  return 0.0;
}

}  // namespace aniso
