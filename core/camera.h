// Pinhole intrinsics in OpenCV's convention (docs/formats.md): camera x right, y down, z forward;
// pixel (x, y) has its centre at integer coordinates, its ray ((x - cx)/fx, (y - cy)/fy, 1).
#pragma once
#include <array>

namespace aniso {

struct Intrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // OpenCV's lens distortion k1 k2 p1 p2 k3 of the stored pixels (zeros: a pinhole); see
  // core/lens.h.
  std::array<double, 5> distortion{};
  bool distorted() const {
    for (double d : distortion)
      if (d != 0) return true;
    return false;
  }
};

}  // namespace aniso
