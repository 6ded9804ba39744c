// Pinhole intrinsics in OpenCV's convention (FORMAT.md): camera x right, y down, z forward; pixel
// (x, y) has its centre at integer coordinates, its ray ((x - cx)/fx, (y - cy)/fy, 1).
#pragma once

namespace aniso {

struct Intrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

}  // namespace aniso
