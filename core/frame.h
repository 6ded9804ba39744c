// The shading frame of a surface point from its geometry buffers (docs/models.md §1): N normalised,
// U made perpendicular to N, W = N x U. The simulator and the fitter both build frames here, from
// the same float buffers, so a noise-free capture is fitted exactly.
#pragma once
#include "core/image.h"
#include "core/local_dir.h"
#include "core/vec.h"

namespace aniso {

struct SurfacePoint {
  Vec3 P, N, U, W;
};

// False where the buffers do not define a frame (zero normal, tangent parallel to the normal).
inline bool make_frame(const Vec3& P, const Vec3& N_in, const Vec3& U_in, SurfacePoint* sp) {
  const Vec3 N = normalize(N_in);
  Vec3 U = U_in - N * dot(U_in, N);
  // A tangent this close to the normal has no usable direction in the surface plane.
  constexpr double kMinTangent = 1e-6;
  if (!(length(N) > 0.5) || !(length(U) > kMinTangent)) return false;
  U = normalize(U);
  *sp = {P, N, U, cross(N, U)};
  return true;
}

inline Vec3 pixel_vec3(const Image& im, int x, int y) {
  return {im.at(x, y, 0), im.at(x, y, 1), im.at(x, y, 2)};
}

// The frame at pixel (x, y) of per-pixel position, normal and tangent buffers.
inline bool frame_at(const Image& P, const Image& N, const Image& U, int x, int y,
                     SurfacePoint* sp) {
  return make_frame(pixel_vec3(P, x, y), pixel_vec3(N, x, y), pixel_vec3(U, x, y), sp);
}

inline LocalDir to_local(const SurfacePoint& sp, const Vec3& d) {
  return {dot(d, sp.U), dot(d, sp.W), dot(d, sp.N)};
}

}  // namespace aniso
