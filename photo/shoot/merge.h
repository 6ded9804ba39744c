// One photo's exposure bracket merged into one linear image (aniso import).
//
// RAW files (photo/shoot/raw.h) come decoded linearly by LibRaw; `color` applies to the others
// only.
//
// Our own merge, not cv::MergeDebevec: the camera's response is not estimated but stated by the
// shoot's `color` (sRGB, gamma or linear, or float EXR), Debevec's merge takes 8-bit images only
// and a response curve, and the fit must know which pixels were clipped in every exposure so that
// it leaves them out. Each code is decoded to linear and divided by its exposure; codes at or
// above the saturation level are dropped, near-black codes (within 2 % of full scale of the black
// level, where quantisation and noise dominate) are used only when nothing else is left, and the
// rest are averaged with weight = exposure (the longer exposure has the better signal-to-noise
// ratio for the same read noise).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "photo/shoot/raw.h"
#include "photo/shoot/shoot.h"

namespace aniso {

struct MergedPhoto {
  Image rgb;                       // linear radiance (pixel = exposure · radiance), 3 channels
  std::vector<uint8_t> saturated;  // 1 = clipped in every exposure of some channel
  std::vector<uint8_t> grey;       // for board detection: tone-mapped luminance, 8 bits
  size_t saturated_pixels = 0;
  std::vector<RawInfo> raw;  // per RAW image of the bracket: camera and white balance
};

// The part of a merged photo kept between the passes of `aniso import` (the sample's estimated
// region), so that a photo is decoded once.
struct MergedCrop {
  int x0 = 0, y0 = 0, w = 0, h = 0;
  Image rgb;
  std::vector<uint8_t> saturated;
  bool contains(int x, int y, int cw, int ch) const {
    return x >= x0 && y >= y0 && x + cw <= x0 + w && y + ch <= y0 + h;
  }
};
MergedCrop crop_merged(const MergedPhoto& m, int x0, int y0, int x1, int y1);

// Reads and merges photo i of the shoot. Throws naming the files when the images of the bracket
// differ in size or channels, or when integer images come without a stated encoding.
// RAW files are developed by `develop` (photo/shoot/raw.h).
MergedPhoto merge_bracket(const Shoot& s, size_t i, RawDevelop develop = RawDevelop::kStreamed);

}  // namespace aniso
