// A small 3-vector and 4x4 rigid transform, kept here so that widely included headers do not pull
// in Eigen. Templated on the scalar so Ceres Jets can flow through the model code.
#pragma once
#include <array>
#include <cmath>

namespace aniso {

template <class T>
struct Vec3T {
  T x{}, y{}, z{};
  Vec3T() = default;
  Vec3T(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  Vec3T operator+(const Vec3T& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3T operator-(const Vec3T& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3T operator-() const { return {-x, -y, -z}; }
  Vec3T operator*(T s) const { return {x * s, y * s, z * s}; }
  Vec3T operator/(T s) const { return {x / s, y / s, z / s}; }
  Vec3T& operator+=(const Vec3T& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

using Vec3 = Vec3T<double>;

template <class T>
inline T dot(const Vec3T<T>& a, const Vec3T<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
inline Vec3T<T> cross(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(const Vec3& a) {
  const double l = length(a);
  return l > 0 ? a / l : Vec3(0, 0, 0);
}
inline bool finite(const Vec3& a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

// Row-major 4x4 rigid transform (docs/formats.md `world_from_camera`).
struct Mat4 {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double operator()(int r, int c) const { return m[r * 4 + c]; }
  double& operator()(int r, int c) { return m[r * 4 + c]; }
  Vec3 point(const Vec3& p) const {
    return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
            m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
            m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
  }
  Vec3 dir(const Vec3& d) const {
    return {m[0] * d.x + m[1] * d.y + m[2] * d.z, m[4] * d.x + m[5] * d.y + m[6] * d.z,
            m[8] * d.x + m[9] * d.y + m[10] * d.z};
  }
  Vec3 translation() const { return {m[3], m[7], m[11]}; }
};

// A camera-to-world pose for a camera at `eye` looking at `target` (OpenCV axes: x right, y down,
// z forward). `up` is the world direction that should appear up in the image.
inline Mat4 look_at(const Vec3& eye, const Vec3& target, const Vec3& up) {
  const Vec3 z = normalize(target - eye);
  Vec3 x = cross(z, up);
  if (length(x) < 1e-9) x = cross(z, Vec3(1, 0, 0));
  if (length(x) < 1e-9) x = cross(z, Vec3(0, 1, 0));
  x = normalize(x);
  const Vec3 y = cross(z, x);  // points down in the image
  Mat4 t;
  t.m = {x.x, y.x, z.x, eye.x, x.y, y.y, z.y, eye.y, x.z, y.z, z.z, eye.z, 0, 0, 0, 1};
  return t;
}

}  // namespace aniso
