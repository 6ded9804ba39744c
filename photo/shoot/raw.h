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
  std::string developed_by;               // which developer of RawDevelop, and its demosaic
};

// Who develops a RAW file's sensor values into linear RGB (the same arithmetic, the same
// clipping; the demosaic differs):
//  - kStreamed: this library, a row at a time from LibRaw's unpacked values, a Bayer mosaic by
//    bilinear interpolation (LibRaw's own, user_qual 0). Holds the unpacked values (2 bytes a pixel
//    for a mosaic) instead of a developed image; sensors it does not handle (X-Trans, four-colour
//    mosaics, Fuji's rotated sensors, Phase One, non-square pixels) go to LibRaw as kLibRaw.
//  - kLibRaw: LibRaw's dcraw_process, bilinear, whole (6 bytes a pixel held).
//  - kLibRawAhd: the same with LibRaw's AHD demosaic (slower; finer colour at sharp edges).
enum class RawDevelop { kStreamed, kLibRaw, kLibRawAhd };
RawDevelop raw_develop_named(const std::string& name);  // "aniso", "libraw", "libraw-ahd"

// The photo developed linearly as rows of 16-bit codes (io/images/image_io.h CodeRows: RGB, the
// largest code clipped), for a merge that reads its bracket row by row. Throws naming the file
// with LibRaw's message when it cannot decode it.
std::unique_ptr<CodeRows> read_raw_rows(const std::string& path, RawInfo* info,
                                        RawDevelop develop = RawDevelop::kStreamed);
// A RAW photo's developed width and height, from its header (nothing unpacked), and what reading
// its rows with `develop` holds: bytes a pixel while the rows are read, and the most a pixel takes
// for the while it is developed before its first row.
struct RawHeader {
  int width = 0, height = 0;
  double held_bytes = 0, developing_bytes = 0;
};
RawHeader raw_header(const std::string& path, RawDevelop develop);

// A DNG of `img` (values in [0, 1]; 16 bits, sRGB primaries, neutral white balance, written
// atomically): kLinear keeps every pixel's three channels (PhotometricInterpretation LinearRaw, as
// a raw converter writes after demosaicing); kBayerRggb keeps one a pixel in an RGGB mosaic
// (PhotometricInterpretation CFA, as a camera's sensor records it, left for LibRaw to demosaic).
// `orientation`: TIFF's Orientation tag (1 as stored; 3 upside down; 6, 8 turned 90 degrees), how
// a camera says it was held.
enum class DngLayout { kLinear, kBayerRggb };
void write_dng(const std::string& path, const Image& img, DngLayout layout, int orientation = 1);

}  // namespace aniso
