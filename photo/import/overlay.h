// The overlay PNG of one imported photo: what `aniso import` saw and concluded, for a person to
// check at a glance (corners found, corners dropped at the sample, the board reprojected through
// the solved pose and lens, the sample's outline and mask).
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"

namespace aniso {

struct OverlayMarks {
  using Points = std::vector<std::array<double, 2>>;
  Points found;               // green circles: corners used
  Points dropped;             // yellow circles: corners on or near the sample, not used
  Points reprojected;         // red crosses: every board corner through the solved pose
  Points outline;             // blue polyline: the sample's outline through the solved pose
  std::vector<uint8_t> mask;  // tinted: the sample pixels of the view (mask_w x mask_h at x0, y0)
  int mask_x0 = 0, mask_y0 = 0, mask_w = 0, mask_h = 0;
  std::string label;
};

// The photo's detection image shrunk for its overlay: each overlay pixel the mean of shrink x
// shrink photo pixels, shrink the smallest integer that brings the long side to kOverlaySide
// pixels or fewer (a 24 MP photo's overlay is 2000 x 1334, not 6000 x 4000).
inline constexpr int kOverlaySide = 2048;
inline int overlay_shrink(int width, int height) {
  return std::max(1, (std::max(width, height) + kOverlaySide - 1) / kOverlaySide);
}
struct OverlayImage {
  std::vector<uint8_t> grey;
  int width = 0, height = 0, shrink = 1;
};
OverlayImage overlay_image(const std::vector<uint8_t>& grey, int width, int height);

// Writes the overlay image with the marks (in the photo's pixels) as an 8-bit RGB PNG
// (atomically).
void write_overlay(const std::string& path, const OverlayImage& img, const OverlayMarks& m);

}  // namespace aniso
