// A float image with interleaved channels: the in-memory form of every EXR, PNG and buffer.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>
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

// True when no value is NaN or infinite: the exponent bits tested in blocks without an early exit
// inside one, which the compiler vectorises (a test per value with a branch does not vectorise).
inline bool all_finite(const std::vector<float>& v) {
  constexpr size_t kBlock = 1024;
  for (size_t i = 0; i < v.size(); i += kBlock) {
    const size_t end = i + kBlock < v.size() ? i + kBlock : v.size();
    uint32_t bad = 0;
    for (size_t j = i; j < end; ++j) {
      uint32_t bits;
      std::memcpy(&bits, &v[j], sizeof bits);
      bad |= (bits & 0x7f800000u) == 0x7f800000u;
    }
    if (bad) return false;
  }
  return true;
}

}  // namespace aniso
