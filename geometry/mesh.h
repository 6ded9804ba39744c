// Triangle meshes for the simulated gonioreflectometer: the classic sample shapes, tessellated
// finely with exact per-vertex normals and reference tangents, and OBJ files with UVs.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec.h"

namespace aniso {

struct TriMesh {
  std::vector<Vec3> P, N, U;             // per vertex: position, unit normal, tangent dP/du
  std::vector<std::array<float, 2>> uv;  // per vertex (glTF convention: v down)
  // Winding is not guaranteed (the sphere's grid is clockwise seen from outside); nothing here
  // culls, and the glTF export orients each triangle by the vertex normals.
  std::vector<std::array<uint32_t, 3>> tri;
  // False for shapes that cannot shadow themselves (a flat square, a disc, a sphere: convex or
  // planar), so the simulator casts no shadow rays for them.
  bool can_self_shadow = true;
  Vec3 center{0, 0, 0}, axis{0, 0, 1};  // for the radial / circular / meridian fields
  // Torus only: radii for the mathematical topology (docs/models.md §4).
  double torus_R = 0, torus_r = 0;
};

struct ShapeOptions {
  int resolution = 128;  // segments around the longest loop
  double torus_R = 1.0, torus_r = 0.4;
};

// "flat" (2x2 square in z = 0, U = +x), "disc" (radius 1 in z = 0, U = +x), "sphere" (radius 1,
// U = dP/du along the parallels), "cylinder" (radius 1, height 2, open, axis z),
// "torus" (axis z, U around the main axis). Throws on an unknown name.
TriMesh make_shape(const std::string& name, const ShapeOptions& opt = {});
const std::vector<std::string>& shape_names();

// Triangle mesh from an OBJ file (v, vt, vn, f; polygons fanned). U = dP/du from the UVs; OBJ's
// v (up) is flipped to glTF's v (down). Throws naming the file and line on bad input. With
// `need_uv` (no fiber field replaces dP/du), a face without texture coordinates, or whose
// coordinates are degenerate, is an error: U, and so psi, would be measured from no axis.
TriMesh load_obj(const std::string& path, bool need_uv = true);

// The named fiber fields ("" keeps the mesh's U), parsed once rather than compared per pixel.
enum class FiberField { kMesh, kRadial, kCircular, kMeridian };
FiberField parse_fiber_field(const std::string& field);

// Any unit vector perpendicular to N, chosen deterministically (fallback for degenerate U).
Vec3 any_perpendicular(const Vec3& N);

// The reference tangent U at point P with normal N for a fiber field (inline: once per traced
// pixel).
inline Vec3 fiber_field_tangent(FiberField field, const Vec3& P, const Vec3& N, const Vec3& U,
                                const Vec3& center, const Vec3& axis) {
  Vec3 t = U;
  if (field == FiberField::kRadial || field == FiberField::kCircular) {
    const Vec3 r = P - center;
    const Vec3 radial = r - axis * dot(r, axis);
    t = field == FiberField::kRadial ? radial : cross(axis, radial);
  } else if (field == FiberField::kMeridian) {
    t = axis;  // toward the pole, projected below
  }
  t = t - N * dot(t, N);
  const double l = length(t);
  // Below this the field is undefined (centre of a disc, pole of a sphere): any tangent will do,
  // the pixel is measure-zero.
  constexpr double kDegenerate = 1e-9;
  return l > kDegenerate ? t / l : any_perpendicular(N);
}
inline Vec3 fiber_field_tangent(const std::string& field, const Vec3& P, const Vec3& N,
                                const Vec3& U, const Vec3& center, const Vec3& axis) {
  return fiber_field_tangent(parse_fiber_field(field), P, N, U, center, axis);
}

}  // namespace aniso
