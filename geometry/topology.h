// The mathematical topology of the classic shapes (docs/models.md §4): how tightly fibers wound on
// a torus or along a sphere's meridians pack, as the topology value s at a point. Shared by the
// simulator, the preview and anyone who renders those shapes.
#pragma once
#include <string>

#include "core/vec.h"
#include "geometry/mesh.h"
#include "models/material.h"

namespace aniso {

// The mathematical topology s_math at a point of a named shape (docs/models.md §4): "torus" (radii
// R, r, axis z) or "sphere" (fibers along meridians, compressed by 1/sin(polar angle)); 0 for
// "none".
double mathematical_topology_at(MathTopology kind, const Vec3& P, const ShapeOptions& shape);

}  // namespace aniso
