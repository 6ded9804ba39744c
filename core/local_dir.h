// A direction in the local frame of a surface point (docs/models.md §1): the one type the shading
// frame (core/frame.h) produces and the models (models/) consume.
#pragma once

namespace aniso {

// A unit direction in the local frame (U, W = N x U, N) of a surface point (docs/models.md §1).
struct LocalDir {
  double u = 0, w = 0, n = 1;
};

}  // namespace aniso
