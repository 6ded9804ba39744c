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

RawDevelop raw_develop_named(const std::string& name) {
  if (name == "aniso") return RawDevelop::kStreamed;
  if (name == "libraw") return RawDevelop::kLibRaw;
  if (name == "libraw-ahd") return RawDevelop::kLibRawAhd;
  throw Error("RAW develop \"" + name + "\": expected aniso, libraw or libraw-ahd");
}

namespace {

using MemImage = std::unique_ptr<libraw_processed_image_t, void (*)(libraw_processed_image_t*)>;

// LibRaw's channel (0..3, 3 the second green) of a 2x2-patterned mosaic at a visible pixel, from
// its `filters` word (LibRaw's FC, usable on a const LibRaw).
int mosaic_channel(unsigned filters, int r, int c) {
  return filters >> (((r << 1 & 14) | (c & 1)) << 1) & 3;
}

std::unique_ptr<LibRaw> open_raw(const std::string& path, RawInfo* info) {
  auto raw = std::make_unique<LibRaw>();
  const int rc = raw->open_file(path.c_str());
  if (rc != LIBRAW_SUCCESS)
    throw Error(path + ": LibRaw cannot open this RAW file: " + libraw_strerror(rc));
  if (info) {
    info->camera = std::string(raw->imgdata.idata.make) + " " + raw->imgdata.idata.model;
    for (int c = 0; c < 4; ++c) info->white_balance[c] = raw->imgdata.color.cam_mul[c];
  }
  return raw;
}

void check_libraw(const std::string& path, int rc, const char* what) {
  if (rc != LIBRAW_SUCCESS)
    throw Error(path + ": LibRaw cannot " + what + " this RAW file: " + libraw_strerror(rc));
}

// The file developed linearly by LibRaw's own pipeline, whole (no transfer curve, no
// auto-brightening, the camera's white balance, sRGB primaries, 16 bits, clipped highlights kept at
// the largest code).
MemImage develop_by_libraw(std::unique_ptr<LibRaw> raw, const std::string& path, bool ahd,
                           bool unpacked = false) {
  auto& p = raw->imgdata.params;
  p.output_bps = 16;
  p.gamm[0] = 1.0;  // linear: no transfer curve
  p.gamm[1] = 1.0;
  p.no_auto_bright = 1;
  p.use_camera_wb = 1;
  p.output_color = 1;  // sRGB primaries, linear
  p.highlight = 0;     // clip: a clipped value stays at the largest code (and is left out)
  p.user_qual = ahd ? 3 : 0;
  if (!unpacked) check_libraw(path, raw->unpack(), "unpack");
  check_libraw(path, raw->dcraw_process(), "process");
  int rc = 0;
  MemImage img(raw->dcraw_make_mem_image(&rc), LibRaw::dcraw_clear_mem);
  check_libraw(path, rc, "render");
  if (img->type != LIBRAW_IMAGE_BITMAP || img->bits != 16 || (img->colors != 3 && img->colors != 1))
    throw Error(path + ": LibRaw returned an unexpected image layout");
  return img;
}

class LibRawRows : public CodeRows {
 public:
  explicit LibRawRows(MemImage img) : img_(std::move(img)) {
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

// LibRaw's unpacked sensor values developed here: a mosaic a row at a time when the photo is
// upright or upside down (whole first when it is turned 90 degrees), three or four channels a
// pixel whole, with LibRaw's own arithmetic for what it
// calls linear output: each value less its black level, times the white balance and 65535 over the
// white level less black, clipped to [0, 65535]; a Bayer mosaic's missing channels the mean of the
// same channel's neighbours in the 3x3 window (LibRaw's bilinear interpolation, user_qual 0); then
// the camera-to-sRGB matrix, clipped again. One difference: an output channel the matrix makes
// from a camera channel that was at the white level anywhere in the pixel's window is written
// 65535, so the merge drops it (LibRaw's matrix can turn a clipped value into an
// unclipped-looking colour). Held: a mosaic's unpacked values (2
// bytes a pixel), else the developed image (6).
// RawRows.TheStreamedDevelopIsLibRawsBilinearOne holds it to LibRaw's dcraw_process.
class StreamedRows : public CodeRows {
 public:
  // `raw` unpacked, its values where unpacked_here says.
  explicit StreamedRows(std::unique_ptr<LibRaw> raw) : raw_(std::move(raw)) {
    const auto& sz = raw_->imgdata.sizes;
    const auto& rd = raw_->imgdata.rawdata;
    const auto& col = raw_->imgdata.color;
    sw_ = sz.width, sh_ = sz.height;
    top_ = sz.top_margin, left_ = sz.left_margin;
    pitch_ = sz.raw_pitch / 2;
    bayer_ = rd.raw_image;
    c3_ = rd.color3_image, c4_ = rd.color4_image;
    if (c3_ || c4_) pitch_ = sz.raw_pitch / (c3_ ? 6 : 8);
    flip_ = sz.flip;
    turned_ = (flip_ & 4) != 0;
    width = turned_ ? sh_ : sw_, height = turned_ ? sw_ : sh_, channels = 3, bits = 16;
    // The white balance as LibRaw's scale_colors takes it with use_camera_wb and highlight 0.
    double pre[4];
    const bool camera_wb = col.cam_mul[0] > 0 && col.cam_mul[2] > 0;
    for (int c = 0; c < 4; ++c) pre[c] = camera_wb ? col.cam_mul[c] : col.pre_mul[c];
    if (pre[1] == 0) pre[1] = 1;
    if (pre[3] == 0) pre[3] = raw_->imgdata.idata.colors < 4 ? pre[1] : 1;
    const double least = *std::min_element(pre, pre + 4);
    black_ = col.black;
    for (int c = 0; c < 4; ++c) cblack_[c] = col.cblack[c];
    pattern_rows_ = col.cblack[4], pattern_cols_ = col.cblack[5];
    if (pattern_rows_ * pattern_cols_ > 0)
      pattern_.assign(col.cblack + 6, col.cblack + 6 + pattern_rows_ * pattern_cols_);
    // LibRaw's unpack found the blacks (from the masked pixels where a camera has them) and moved
    // their common part into `black`; its scale_colors divides by the white level less that part.
    white_ = clip_level(col.maximum);
    for (int c = 0; c < 4; ++c)
      scale_[c] = static_cast<float>(pre[c] / least * 65535.0 /
                                     std::max(1.0, double(col.maximum) - black_));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) cam_[r][c] = col.rgb_cam[r][c];
    out_.resize(static_cast<size_t>(width) * 3);
    // Developed whole in the sensor's order where turned (then read by columns) and where LibRaw
    // holds three or four channels a pixel (8 bytes where the developed image takes 6: LibRaw's
    // copy is let go).
    if (turned_ || !bayer_) {
      whole_.resize(static_cast<size_t>(sw_) * sh_ * 3);
      for (int r = 0; r < sh_; ++r)
        develop_row(r, whole_.data() + static_cast<size_t>(r) * sw_ * 3);
      if (!bayer_) c3_ = nullptr, c4_ = nullptr, raw_->recycle();
    }
  }

  // Whether this developer handles the file's layout: a 2x2 three-colour Bayer mosaic or three or
  // four channels a pixel, square pixels, no Fuji or Phase One peculiarities.
  static bool handles(const LibRaw& raw) {
    const auto& id = raw.imgdata.idata;
    const auto& sz = raw.imgdata.sizes;
    if (sz.pixel_aspect != 1 || raw.imgdata.rawdata.ioparams.fuji_width) return false;
    if (raw.imgdata.color.phase_one_data.format) return false;
    if (id.filters == 0) return id.colors == 3;
    if (id.filters < 1000 || id.colors != 3) return false;  // X-Trans, leaf, CMYG
    // A 2x2 pattern repeated: every pair of rows the same, R, B and G all present.
    int seen[4] = {0, 0, 0, 0};
    for (int r = 0; r < 8; ++r)
      for (int c = 0; c < 2; ++c) {
        const int k = mosaic_channel(id.filters, r, c);
        if (k != mosaic_channel(id.filters, r & 1, c)) return false;
        ++seen[k == 3 ? 1 : k];
      }
    return seen[0] && seen[1] && seen[2];
  }
  // After unpack: whether its values are where this developer reads them (a mosaic in raw_image,
  // three or four channels in color3_image or color4_image; not a float DNG's float buffers).
  static bool unpacked_here(const LibRaw& raw) {
    const auto& rd = raw.imgdata.rawdata;
    return raw.imgdata.idata.filters ? rd.raw_image != nullptr
                                     : rd.color3_image != nullptr || rd.color4_image != nullptr;
  }

  // The raw value at which a value is taken as clipped: the white level as written, or, where the
  // file's largest value lies within a quarter of it and at least kPlateau values sit there, that
  // value (a sensor that saturates below its nominal white level, which LibRaw's adjust_maximum
  // also looks for). The scale stays the nominal white level's, the same for every exposure of a
  // bracket (LibRaw's adjust_maximum changes it file by file).
  unsigned clip_level(unsigned white) const {
    constexpr size_t kPlateau = 16;
    // Row by row over the visible values (a plain loop the compiler vectorises), then, only where
    // the largest lies in the quarter below the white level, a count of the values there.
    const int per = bayer_ ? 1 : c3_ ? 3 : 4;
    const uint16_t* base = bayer_ ? bayer_ : c3_ ? &c3_[0][0] : &c4_[0][0];
    auto row = [&](int r) { return base + (static_cast<size_t>(r + top_) * pitch_ + left_) * per; };
    const size_t n = static_cast<size_t>(sw_) * per;
    unsigned top = 0;
    for (int r = 0; r < sh_; ++r) {
      const uint16_t* p = row(r);
      uint16_t m = 0;
      for (size_t i = 0; i < n; ++i) m = std::max(m, p[i]);
      top = std::max<unsigned>(top, m);
    }
    if (!(top < white && top > 0.75 * white)) return white;
    size_t at_top = 0;
    for (int r = 0; r < sh_ && at_top < kPlateau; ++r) {
      const uint16_t* p = row(r);
      for (size_t i = 0; i < n; ++i) at_top += p[i] == top;
    }
    return at_top >= kPlateau ? top : white;
  }

  const uint16_t* next() override {
    const int y = y_++;
    if (!turned_) {
      const int r = (flip_ & 2) ? sh_ - 1 - y : y;
      if (whole_.empty())
        develop_row(r, out_.data());
      else
        std::copy_n(whole_.data() + static_cast<size_t>(r) * sw_ * 3, sw_ * 3, out_.data());
      if (flip_ & 1)
        for (int x = 0; x < sw_ / 2; ++x)
          for (int c = 0; c < 3; ++c) std::swap(out_[3 * x + c], out_[3 * (sw_ - 1 - x) + c]);
      return out_.data();
    }
    // Turned: the output's row y is the sensor's column, its x the sensor's row.
    for (int x = 0; x < width; ++x) {
      int r = x, c = y;
      if (flip_ & 2) r = sh_ - 1 - r;
      if (flip_ & 1) c = sw_ - 1 - c;
      const uint16_t* p = whole_.data() + (static_cast<size_t>(r) * sw_ + c) * 3;
      for (int k = 0; k < 3; ++k) out_[3 * static_cast<size_t>(x) + k] = p[k];
    }
    return out_.data();
  }

 private:
  int mosaic_index(int r, int c) const {  // LibRaw's channel 0..3 (3: the second green)
    return mosaic_channel(raw_->imgdata.idata.filters, r, c);
  }
  int colour(int r, int c) const {  // 0 R, 1 G, 2 B of the mosaic at a visible pixel
    const int k = mosaic_index(r, c);
    return k == 3 ? 1 : k;
  }
  double black(int r, int c, int k) const {
    double b = black_ + cblack_[k];
    if (!pattern_.empty()) b += pattern_[(r % pattern_rows_) * pattern_cols_ + c % pattern_cols_];
    return b;
  }
  // The scaled value of channel k at a visible pixel whose raw value is v; `clipped` set when v
  // is at the white level.
  float scaled(unsigned v, int r, int c, int k, bool* clipped) const {
    if (v >= white_) *clipped = true;
    const double s = (double(v) - black(r, c, k)) * scale_[k];
    return static_cast<float>(std::clamp(s, 0.0, 65535.0));
  }
  float mosaic_at(int r, int c, bool* clipped) const {
    const unsigned v = bayer_[static_cast<size_t>(r + top_) * pitch_ + c + left_];
    return scaled(v, r, c, mosaic_index(r, c), &clipped[colour(r, c)]);
  }
  void develop_row(int r, uint16_t* out) const {
    for (int c = 0; c < sw_; ++c) {
      float v[3] = {0, 0, 0};
      bool clipped[3] = {false, false, false};  // per camera channel
      if (bayer_) {
        float sum[3] = {0, 0, 0};
        int n[3] = {0, 0, 0};
        const int own = colour(r, c);
        v[own] = mosaic_at(r, c, clipped);
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int rr = r + dy, cc = c + dx;
            if ((dy == 0 && dx == 0) || rr < 0 || rr >= sh_ || cc < 0 || cc >= sw_) continue;
            const int k = colour(rr, cc);
            if (k == own) continue;
            sum[k] += mosaic_at(rr, cc, clipped), ++n[k];
          }
        for (int k = 0; k < 3; ++k)
          if (k != own) v[k] = n[k] ? sum[k] / n[k] : 0;
      } else {
        const size_t at = static_cast<size_t>(r + top_) * pitch_ + c + left_;
        for (int k = 0; k < 3; ++k)
          v[k] = scaled(c3_ ? c3_[at][k] : c4_[at][k], r, c, k, &clipped[k]);
      }
      uint16_t* o = out + 3 * static_cast<size_t>(c);
      for (int k = 0; k < 3; ++k) {
        const float m = cam_[k][0] * v[0] + cam_[k][1] * v[1] + cam_[k][2] * v[2];
        const bool lost = (clipped[0] && std::abs(cam_[k][0]) > 1e-3f) ||
                          (clipped[1] && std::abs(cam_[k][1]) > 1e-3f) ||
                          (clipped[2] && std::abs(cam_[k][2]) > 1e-3f);
        o[k] = lost ? 65535 : static_cast<uint16_t>(std::clamp(m, 0.f, 65535.f) + 0.5f);
      }
    }
  }

  std::unique_ptr<LibRaw> raw_;
  const uint16_t* bayer_ = nullptr;
  const uint16_t (*c3_)[3] = nullptr;
  const uint16_t (*c4_)[4] = nullptr;
  size_t pitch_ = 0;
  int sw_ = 0, sh_ = 0, top_ = 0, left_ = 0, flip_ = 0;
  bool turned_ = false;
  double black_ = 0, cblack_[4] = {0, 0, 0, 0};
  int pattern_rows_ = 0, pattern_cols_ = 0;
  std::vector<double> pattern_;
  unsigned white_ = 65535;
  float scale_[4] = {1, 1, 1, 1}, cam_[3][4] = {};
  std::vector<uint16_t> out_, whole_;
  int y_ = 0;
};

}  // namespace

RawHeader raw_header(const std::string& path, RawDevelop develop) {
  auto raw = open_raw(path, nullptr);
  const auto& sz = raw->imgdata.sizes;
  const bool turned = (sz.flip & 4) != 0;
  RawHeader h;
  h.width = turned ? sz.height : sz.width;
  h.height = turned ? sz.width : sz.height;
  if (develop == RawDevelop::kStreamed && StreamedRows::handles(*raw)) {
    // A mosaic's unpacked values (and the developed image when turned); else the developed
    // image, made from LibRaw's up to four channels a pixel.
    const bool mosaic = raw->imgdata.idata.filters != 0;
    h.held_bytes = mosaic ? 2 + (turned ? 6 : 0) : 6;
    h.developing_bytes = mosaic ? 0 : 8;
  } else {
    h.held_bytes = 6, h.developing_bytes = 16;  // LibRaw's image, its working buffers
  }
  return h;
}

std::unique_ptr<CodeRows> read_raw_rows(const std::string& path, RawInfo* info,
                                        RawDevelop develop) {
  auto raw = open_raw(path, info);
  bool unpacked = false;
  if (develop == RawDevelop::kStreamed && StreamedRows::handles(*raw)) {
    check_libraw(path, raw->unpack(), "unpack");
    unpacked = true;
    if (StreamedRows::unpacked_here(*raw)) {
      if (info) info->developed_by = "aniso, streamed (bilinear demosaic)";
      return std::make_unique<StreamedRows>(std::move(raw));
    }
  }
  const bool ahd = develop == RawDevelop::kLibRawAhd;
  if (info) info->developed_by = ahd ? "LibRaw (AHD demosaic)" : "LibRaw (bilinear demosaic)";
  return std::make_unique<LibRawRows>(develop_by_libraw(std::move(raw), path, ahd, unpacked));
}

void write_dng(const std::string& path, const Image& img, DngLayout layout, int orientation) {
  const bool cfa = layout == DngLayout::kBayerRggb;
  write_atomically(path, [&](const std::string& tmp) {
    TIFF* t = TIFFOpen(tmp.c_str(), "w");
    if (!t) throw Error(tmp + ": cannot create DNG");
    std::unique_ptr<TIFF, void (*)(TIFF*)> hold(t, TIFFClose);
    const uint16_t photometric_linear_raw = 34892, photometric_cfa = 32803;
    const uint8_t version[4] = {1, 4, 0, 0};
    // XYZ (D65) -> camera: the camera's RGB is linear sRGB.
    const float xyz_to_cam[9] = {3.2404542f, -1.5371385f, -0.4985314f, -0.9692660f, 1.8760108f,
                                 0.0415560f, 0.0556434f,  -0.2040259f, 1.0572252f};
    const float neutral[3] = {1, 1, 1};
    const int samples = cfa ? 1 : 3;
    TIFFSetField(t, TIFFTAG_SUBFILETYPE, 0);
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(img.width));
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(img.height));
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 16);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, samples);
    TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, cfa ? photometric_cfa : photometric_linear_raw);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_ORIENTATION, static_cast<uint16_t>(orientation));
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP,
                 static_cast<uint32_t>(std::max(1, 65536 / (2 * samples * img.width))));
    if (cfa) {  // R G / G B, as most cameras' sensors
      const uint16_t dim[2] = {2, 2};
      const uint8_t pattern[4] = {0, 1, 1, 2};
      TIFFSetField(t, TIFFTAG_CFAREPEATPATTERNDIM, dim);
      TIFFSetField(t, TIFFTAG_CFAPATTERN, 4, pattern);
    }
    TIFFSetField(t, TIFFTAG_MAKE, "aniso");
    TIFFSetField(t, TIFFTAG_MODEL, "synth");
    TIFFSetField(t, TIFFTAG_DNGVERSION, version);
    TIFFSetField(t, TIFFTAG_UNIQUECAMERAMODEL, "aniso synth");
    TIFFSetField(t, TIFFTAG_COLORMATRIX1, 9, xyz_to_cam);
    TIFFSetField(t, TIFFTAG_ASSHOTNEUTRAL, 3, neutral);
    TIFFSetField(t, TIFFTAG_CALIBRATIONILLUMINANT1, 21);  // D65
    std::vector<uint16_t> row(static_cast<size_t>(img.width) * samples);
    for (int y = 0; y < img.height; ++y) {
      for (int x = 0; x < img.width; ++x)
        for (int s = 0; s < samples; ++s) {
          // The mosaic keeps one channel a pixel: R at even x and y, B at odd, G between.
          const int c = cfa ? (x & 1) + (y & 1) : s;
          const float v = img.at(x, y, img.channels == 1 ? 0 : c);
          if (!std::isfinite(v)) throw Error(path + ": refusing to write a non-finite value");
          row[samples * static_cast<size_t>(x) + s] =
              static_cast<uint16_t>(std::lround(std::clamp(v, 0.f, 1.f) * 65535.0));
        }
      if (TIFFWriteScanline(t, row.data(), static_cast<uint32_t>(y), 0) < 0)
        throw Error(tmp + ": cannot write DNG row " + std::to_string(y));
    }
  });
}

}  // namespace aniso
