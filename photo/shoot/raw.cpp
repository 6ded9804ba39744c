#include "photo/shoot/raw.h"

#include <libraw/libraw.h>
#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "core/error.h"
#include "io/files/files.h"

namespace aniso {

bool is_raw_photo(const std::string& path) {
  const std::string e = lower_ext(path);
  for (const char* r :
       {".dng", ".cr2", ".cr3", ".nef", ".arw", ".orf", ".rw2", ".raf", ".pef", ".srw"})
    if (e == r) return true;
  return false;
}

void raw_dimensions(const std::string& path, int* w, int* h) {
  auto raw = std::make_unique<LibRaw>();
  const int rc = raw->open_file(path.c_str());
  if (rc != LIBRAW_SUCCESS)
    throw Error(path + ": LibRaw cannot open this RAW file: " + libraw_strerror(rc));
  const auto& sz = raw->imgdata.sizes;
  const bool turned = sz.flip == 5 || sz.flip == 6;
  *w = turned ? sz.height : sz.width;
  *h = turned ? sz.width : sz.height;
}

namespace {

using MemImage = std::unique_ptr<libraw_processed_image_t, void (*)(libraw_processed_image_t*)>;

// The file developed linearly by LibRaw (no transfer curve, no auto-brightening, the camera's
// white balance, sRGB primaries, 16 bits, clipped highlights kept at the largest code).
MemImage develop(const std::string& path, RawInfo* info) {
  auto raw = std::make_unique<LibRaw>();
  auto check = [&](int rc, const char* what) {
    if (rc != LIBRAW_SUCCESS)
      throw Error(path + ": LibRaw cannot " + what + " this RAW file: " + libraw_strerror(rc));
  };
  check(raw->open_file(path.c_str()), "open");
  auto& p = raw->imgdata.params;
  p.output_bps = 16;
  p.gamm[0] = 1.0;  // linear: no transfer curve
  p.gamm[1] = 1.0;
  p.no_auto_bright = 1;
  p.use_camera_wb = 1;
  p.output_color = 1;  // sRGB primaries, linear
  p.highlight = 0;     // clip: a clipped value stays at the largest code (and is left out)
  check(raw->unpack(), "unpack");
  check(raw->dcraw_process(), "process");
  int rc = 0;
  MemImage img(raw->dcraw_make_mem_image(&rc), LibRaw::dcraw_clear_mem);
  check(rc, "render");
  if (img->type != LIBRAW_IMAGE_BITMAP || img->bits != 16 || (img->colors != 3 && img->colors != 1))
    throw Error(path + ": LibRaw returned an unexpected image layout");
  if (info) {
    info->camera = std::string(raw->imgdata.idata.make) + " " + raw->imgdata.idata.model;
    for (int c = 0; c < 4; ++c) info->white_balance[c] = raw->imgdata.color.cam_mul[c];
  }
  return img;
}

class RawRows : public CodeRows {
 public:
  explicit RawRows(MemImage img) : img_(std::move(img)) {
    width = img_->width, height = img_->height, channels = img_->colors, bits = 16;
  }
  const uint16_t* next() override {
    const auto* d = reinterpret_cast<const uint16_t*>(img_->data);
    return d + static_cast<size_t>(y_++) * width * channels;
  }

 private:
  MemImage img_;
  size_t y_ = 0;
};

}  // namespace

std::unique_ptr<CodeRows> read_raw_rows(const std::string& path, RawInfo* info) {
  return std::make_unique<RawRows>(develop(path, info));
}

void write_linear_dng(const std::string& path, const Image& img) {
  write_atomically(path, [&](const std::string& tmp) {
    TIFF* t = TIFFOpen(tmp.c_str(), "w");
    if (!t) throw Error(tmp + ": cannot create DNG");
    std::unique_ptr<TIFF, void (*)(TIFF*)> hold(t, TIFFClose);
    const uint16_t photometric_linear_raw = 34892;
    const uint8_t version[4] = {1, 4, 0, 0};
    // XYZ (D65) -> camera: the camera's RGB is linear sRGB.
    const float xyz_to_cam[9] = {3.2404542f, -1.5371385f, -0.4985314f, -0.9692660f, 1.8760108f,
                                 0.0415560f, 0.0556434f,  -0.2040259f, 1.0572252f};
    const float neutral[3] = {1, 1, 1};
    TIFFSetField(t, TIFFTAG_SUBFILETYPE, 0);
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(img.width));
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(img.height));
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 16);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 3);
    TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, photometric_linear_raw);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP,
                 static_cast<uint32_t>(std::max(1, 65536 / (6 * img.width))));
    TIFFSetField(t, TIFFTAG_MAKE, "aniso");
    TIFFSetField(t, TIFFTAG_MODEL, "synth");
    TIFFSetField(t, TIFFTAG_DNGVERSION, version);
    TIFFSetField(t, TIFFTAG_UNIQUECAMERAMODEL, "aniso synth");
    TIFFSetField(t, TIFFTAG_COLORMATRIX1, 9, xyz_to_cam);
    TIFFSetField(t, TIFFTAG_ASSHOTNEUTRAL, 3, neutral);
    TIFFSetField(t, TIFFTAG_CALIBRATIONILLUMINANT1, 21);  // D65
    std::vector<uint16_t> row(static_cast<size_t>(img.width) * 3);
    for (int y = 0; y < img.height; ++y) {
      for (int x = 0; x < img.width; ++x)
        for (int c = 0; c < 3; ++c) {
          const float v = img.at(x, y, img.channels == 1 ? 0 : c);
          if (!std::isfinite(v)) throw Error(path + ": refusing to write a non-finite value");
          row[3 * static_cast<size_t>(x) + c] =
              static_cast<uint16_t>(std::lround(std::clamp(v, 0.f, 1.f) * 65535.0));
        }
      if (TIFFWriteScanline(t, row.data(), static_cast<uint32_t>(y), 0) < 0)
        throw Error(tmp + ": cannot write DNG row " + std::to_string(y));
    }
  });
}

}  // namespace aniso
