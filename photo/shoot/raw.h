// Camera RAW photos (.dng .cr2 .nef .arw ...) decoded linearly by LibRaw for `aniso import`: no
// gamma curve, no automatic brightening, the camera's own white balance, sRGB primaries, 16 bits.
// So the shoot's `color` does not apply to them. Also the writer of a linear DNG, which the photo
// simulator uses to hand `import` a real RAW file.
#pragma once
#include <array>
#include <string>

#include "core/image.h"
#include "io/images/image_io.h"

namespace aniso {

// By extension: dng, cr2, cr3, nef, arw, orf, rw2, raf, pef, srw.
bool is_raw_photo(const std::string& path);

struct RawInfo {
  std::string camera;                     // make and model as LibRaw reads them
  std::array<double, 4> white_balance{};  // the camera's multipliers (R, G, B, G2), as applied
};

// The photo developed by LibRaw as rows of linear 16-bit codes (io/images/image_io.h CodeRows: RGB,
// the largest code clipped; 6 bytes a pixel held, LibRaw's own buffers freed before it returns),
// for a merge that reads its bracket row by row. Throws naming the file with LibRaw's message
// when it cannot decode it.
std::unique_ptr<CodeRows> read_raw_rows(const std::string& path, RawInfo* info);
// A RAW photo's developed width and height, from its header (nothing unpacked).
void raw_dimensions(const std::string& path, int* w, int* h);

// A linear DNG (PhotometricInterpretation LinearRaw, 16 bits, 3 samples, sRGB primaries, neutral
// white balance) of `img` (values in [0, 1]). Written atomically.
void write_linear_dng(const std::string& path, const Image& img);

}  // namespace aniso
