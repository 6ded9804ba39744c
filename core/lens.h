// OpenCV's lens model (k1 k2 p1 p2 k3) on normalized image coordinates: where a pinhole ray
// (x, y, 1) lands on the sensor, and back. Shared by the photo simulator and `aniso import`, so
// the two agree on one definition, and by the ray caster; OpenCV's own calls are used where OpenCV
// solves (calibration, pose).
#pragma once
#include <array>
#include <cmath>

#include "core/camera.h"
#include "core/vec.h"

namespace aniso {

// Normalized undistorted (x, y) -> normalized distorted.
inline void distort_normalized(const std::array<double, 5>& d, double x, double y, double* xd,
                               double* yd) {
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  *xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  *yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
}

// The inverse by fixed-point iteration (as OpenCV's undistortPoints, but iterated to 1e-14).
// Returns false where it does not converge (far outside the calibrated field).
inline bool undistort_normalized(const std::array<double, 5>& d, double xd, double yd, double* x,
                                 double* y) {
  double u = xd, v = yd;
  for (int it = 0; it < 100; ++it) {
    const double r2 = u * u + v * v;
    const double radial = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
    const double dx = 2 * d[2] * u * v + d[3] * (r2 + 2 * u * u);
    const double dy = d[2] * (r2 + 2 * v * v) + 2 * d[3] * u * v;
    if (!(radial > 0.1)) return false;
    const double nu = (xd - dx) / radial, nv = (yd - dy) / radial;
    const double step = std::abs(nu - u) + std::abs(nv - v);
    u = nu;
    v = nv;
    if (step < 1e-14) break;
  }
  double cx, cy;
  distort_normalized(d, u, v, &cx, &cy);
  if (!(std::abs(cx - xd) + std::abs(cy - yd) < 1e-9)) return false;
  *x = u;
  *y = v;
  return true;
}

// The camera-space ray (x, y, 1) of pixel (px, py) of a possibly distorted image; false where the
// lens model cannot be inverted.
inline bool pixel_ray(const Intrinsics& k, double px, double py, Vec3* ray) {
  double x, y;
  if (!undistort_normalized(k.distortion, (px - k.cx) / k.fx, (py - k.cy) / k.fy, &x, &y))
    return false;
  *ray = {x, y, 1.0};
  return true;
}

// Where the ray of pixel (px, py) meets the world plane z = plane_z, for a camera on the -z side
// looking toward +z (a board and the sample on it); false where it does not.
inline bool pixel_on_plane(const Intrinsics& k, const Mat4& world_from_camera, double px, double py,
                           double plane_z, Vec3* P) {
  Vec3 r;
  if (!pixel_ray(k, px, py, &r)) return false;
  const Vec3 d = world_from_camera.dir(r), e = world_from_camera.translation();
  if (!(d.z > 0) || !(e.z < plane_z)) return false;
  *P = e + d * ((plane_z - e.z) / d.z);
  return true;
}

// Where a camera-space point lands, in pixels (point in front of the camera).
inline void project_point(const Intrinsics& k, const Vec3& pc, double* px, double* py) {
  double xd, yd;
  distort_normalized(k.distortion, pc.x / pc.z, pc.y / pc.z, &xd, &yd);
  *px = k.cx + k.fx * xd;
  *py = k.cy + k.fy * yd;
}

}  // namespace aniso
