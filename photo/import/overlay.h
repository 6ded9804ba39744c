// The overlay PNG of one imported photo: what `aniso import` saw and concluded, for a person to
// check at a glance (corners found, corners dropped at the sample, the board reprojected through
// the solved pose and lens, the sample's outline and mask).
#pragma once
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

// Writes `grey` (values in [0, 1]) with the marks as an 8-bit RGB PNG (atomically).
void write_overlay(const std::string& path, const Image& grey, const OverlayMarks& m);

}  // namespace aniso
