// Bilinear sampling with wrap-around in glTF texture coordinates ((0,0) the top-left corner of
// the image, u right, v down, texel centres at ((i + 0.5)/w, (j + 0.5)/h)): the four texels and
// their weights. Shared by topology maps, per-texel topology fits and their ground truth.
#pragma once
#include <cmath>

#include "core/image.h"

namespace aniso {

struct BilinearTaps {
  int index[4];  // y * w + x
  double weight[4];
};

// With `repeat` false the border texels are repeated outward (glTF's clamp-to-edge) instead.
inline BilinearTaps bilinear_taps(double u, double v, int w, int h, bool repeat) {
  const double x = u * w - 0.5, y = v * h - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const double tx = x - fx, ty = y - fy;
  auto wrap = [repeat](long i, int n) {
    return repeat ? static_cast<int>(((i % n) + n) % n)
                  : static_cast<int>(i < 0    ? 0
                                     : i >= n ? n - 1
                                              : i);
  };
  const int x0 = wrap(static_cast<long>(fx), w), x1 = wrap(static_cast<long>(fx) + 1, w);
  const int y0 = wrap(static_cast<long>(fy), h), y1 = wrap(static_cast<long>(fy) + 1, h);
  return {{y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1},
          {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty}};
}

inline BilinearTaps bilinear_wrap(double u, double v, int w, int h) {
  return bilinear_taps(u, v, w, h, true);
}

// The first channel of `img` at (u, v), bilinear with wrap-around.
inline double sample_first_channel(const Image& img, double u, double v) {
  const BilinearTaps t = bilinear_wrap(u, v, img.width, img.height);
  double s = 0;
  for (int k = 0; k < 4; ++k)
    s += t.weight[k] * img.px[static_cast<size_t>(t.index[k]) * img.channels];
  return s;
}

}  // namespace aniso
