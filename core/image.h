// A float image with interleaved channels: the in-memory form of every EXR, PNG and buffer.
#pragma once
#include <cstddef>
#include <vector>

namespace aniso {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<float> px;

  Image() = default;
  Image(int w, int h, int c, float fill = 0.f)
      : width(w), height(h), channels(c), px(static_cast<size_t>(w) * h * c, fill) {}
  float& at(int x, int y, int ch) {
    return px[(static_cast<size_t>(y) * width + x) * channels + ch];
  }
  float at(int x, int y, int ch) const {
    return px[(static_cast<size_t>(y) * width + x) * channels + ch];
  }
  bool empty() const { return px.empty(); }
};

}  // namespace aniso
