#include "io/images/image_codecs.h"

#include <jpeglib.h>
#include <png.h>
#include <tiffio.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "core/error.h"
#include "io/files/files.h"

namespace aniso {

namespace {

// Rows of `channels` interleaved codes (uint8, uint16 or float) into the output image.
template <class T>
void put_row(const T* row, int width, int channels, double scale, int y, Image* img) {
  const int c_out = img->channels;
  for (int x = 0; x < width; ++x)
    for (int c = 0; c < c_out; ++c)
      img->at(x, y, c) = static_cast<float>(row[x * channels + c] * scale);
}

Image new_image(int width, int height, int channels) {
  return Image(width, height, channels >= 3 ? 3 : 1);
}

class File {
 public:
  explicit File(const std::string& path, const char* mode) : f_(std::fopen(path.c_str(), mode)) {
    if (!f_) throw Error(path + ": cannot open");
  }
  ~File() { std::fclose(f_); }
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  FILE* get() const { return f_; }

 private:
  FILE* f_;
};

// ---- PNG ---------------------------------------------------------------------------------------

struct PngMessage {
  char text[200] = "";
};

[[noreturn]] void png_error_to_jump(png_structp png, png_const_charp msg) {
  auto* m = static_cast<PngMessage*>(png_get_error_ptr(png));
  std::snprintf(m->text, sizeof m->text, "%s", msg);
  png_longjmp(png, 1);
}
void png_ignore_warning(png_structp, png_const_charp) {}

// Everything a decode touches after setjmp lives here, on the heap, behind a pointer the
// jumping frame never changes: nothing of it is left indeterminate by a longjmp.
struct PngRead {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngMessage msg;
  std::vector<unsigned char> buf;
  std::vector<png_bytep> rows;
  ~PngRead() { png_destroy_read_struct(&png, info ? &info : nullptr, nullptr); }
};

}  // namespace

ImageKind sniff_image(const std::string& path) {
  unsigned char b[8] = {};
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return ImageKind::kOther;
  const size_t n = std::fread(b, 1, sizeof b, f);
  std::fclose(f);
  static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n >= 8 && std::memcmp(b, png_sig, 8) == 0) return ImageKind::kPng;
  if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) return ImageKind::kJpeg;
  if (n >= 4 && ((b[0] == 'I' && b[1] == 'I' && b[2] == 42 && b[3] == 0) ||
                 (b[0] == 'M' && b[1] == 'M' && b[2] == 0 && b[3] == 42)))
    return ImageKind::kTiff;
  return ImageKind::kOther;
}

namespace {

// A PNG's rows as codes. Non-interlaced files are read a row at a time; an interlaced one is read
// whole at once (its passes fill every row), then served row by row.
class PngRows : public CodeRows {
 public:
  PngRows(const std::string& path, const SizeCheck& check)
      : path_(path), file_(path, "rb"), r_(std::make_unique<PngRead>()) {
    r_->png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r_->msg, png_error_to_jump,
                                     png_ignore_warning);
    if (!r_->png) throw Error(path + ": out of memory for the PNG decoder");
    r_->info = png_create_info_struct(r_->png);
    if (setjmp(png_jmpbuf(r_->png))) throw Error(path + ": cannot decode PNG: " + r_->msg.text);
    png_init_io(r_->png, file_.get());
    png_read_info(r_->png, r_->info);
    const png_uint_32 w = png_get_image_width(r_->png, r_->info),
                      h = png_get_image_height(r_->png, r_->info);
    check(w, h);
    const int type = png_get_color_type(r_->png, r_->info);
    if (type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(r_->png);
    if (type == PNG_COLOR_TYPE_GRAY && png_get_bit_depth(r_->png, r_->info) < 8)
      png_set_expand_gray_1_2_4_to_8(r_->png);
#if __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if (png_get_bit_depth(r_->png, r_->info) == 16) png_set_swap(r_->png);
#endif
    png_set_strip_alpha(r_->png);
    const int passes = png_set_interlace_handling(r_->png);
    png_read_update_info(r_->png, r_->info);
    width = static_cast<int>(w), height = static_cast<int>(h);
    channels = png_get_channels(r_->png, r_->info);
    bits = png_get_bit_depth(r_->png, r_->info);
    const size_t stride = png_get_rowbytes(r_->png, r_->info);
    if (passes > 1) {
      r_->buf.resize(stride * h);
      r_->rows.resize(h);
      for (png_uint_32 y = 0; y < h; ++y) r_->rows[y] = r_->buf.data() + y * stride;
      png_read_image(r_->png, r_->rows.data());
    } else {
      r_->buf.resize(stride);
    }
    out_.resize(static_cast<size_t>(width) * channels);
  }
  const uint16_t* next() override {
    if (r_->rows.empty()) read_row();
    const unsigned char* row = r_->rows.empty() ? r_->buf.data() : r_->rows[y_];
    ++y_;
    if (bits == 16)
      std::memcpy(out_.data(), row, out_.size() * sizeof(uint16_t));
    else
      std::copy(row, row + out_.size(), out_.begin());
    return out_.data();
  }

 private:
  // One row into buf, the jump back from libpng's error handler set here.
  void read_row() {
    if (setjmp(png_jmpbuf(r_->png))) throw Error(path_ + ": cannot decode PNG: " + r_->msg.text);
    png_read_row(r_->png, r_->buf.data(), nullptr);
  }
  std::string path_;
  File file_;
  std::unique_ptr<PngRead> r_;
  std::vector<uint16_t> out_;
  size_t y_ = 0;
};

// A whole image from rows of codes, scaled to [0, 1].
LoadedImage whole_image(CodeRows& rows) {
  LoadedImage out;
  out.bits = rows.bits;
  out.image = new_image(rows.width, rows.height, rows.channels);
  const double scale = rows.bits == 16 ? 1.0 / 65535 : 1.0 / 255;
  for (int y = 0; y < rows.height; ++y)
    put_row(rows.next(), rows.width, rows.channels, scale, y, &out.image);
  return out;
}

}  // namespace

std::unique_ptr<CodeRows> png_rows(const std::string& path, const SizeCheck& check) {
  return std::make_unique<PngRows>(path, check);
}

LoadedImage decode_png(const std::string& path, const SizeCheck& check) {
  PngRows rows(path, check);
  return whole_image(rows);
}

namespace {

void png_append(png_structp png, png_bytep data, png_size_t n) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), n);
}
void png_no_flush(png_structp) {}

struct PngWrite {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngMessage msg;
  std::string bytes;
  std::vector<png_bytep> rows;
  ~PngWrite() { png_destroy_write_struct(&png, info ? &info : nullptr); }
};

}  // namespace

namespace {

// PNG bytes of `h` rows of `stride` bytes (big-endian samples) at `data`. `filter`: libpng's
// adaptive choice per row (photographs compress better) or none (masks: runs of equal bytes,
// which zlib's run-length strategy takes directly).
std::string png_bytes(const std::string& path, const unsigned char* data, int w, int h, int bits,
                      int channels, size_t stride, double dpi, bool filter) {
  const auto wr = std::make_unique<PngWrite>();
  wr->rows.resize(h);
  for (int y = 0; y < h; ++y) wr->rows[y] = const_cast<unsigned char*>(data) + y * stride;
  wr->png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &wr->msg, png_error_to_jump,
                                    png_ignore_warning);
  if (!wr->png) throw Error(path + ": out of memory for the PNG encoder");
  wr->info = png_create_info_struct(wr->png);
  if (setjmp(png_jmpbuf(wr->png))) throw Error(path + ": cannot encode PNG: " + wr->msg.text);
  png_set_write_fn(wr->png, &wr->bytes, png_append, png_no_flush);
  png_set_compression_level(wr->png, 1);  // fast: these are images we write many of
  if (!filter) {
    png_set_filter(wr->png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
    png_set_compression_strategy(wr->png, Z_RLE);
  }
  png_set_IHDR(wr->png, wr->info, w, h, bits,
               channels == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (dpi > 0) {
    const auto ppm = static_cast<png_uint_32>(std::lround(dpi / 0.0254));
    png_set_pHYs(wr->png, wr->info, ppm, ppm, PNG_RESOLUTION_METER);
  }
  // Who wrote it (io/files/files.h: an output replaces only its own kind).
  std::string software = output_stamp(path);
  png_text text{};
  text.compression = PNG_TEXT_COMPRESSION_NONE;
  text.key = const_cast<char*>("Software");
  text.text = software.data();
  text.text_length = software.size();
  png_set_text(wr->png, wr->info, &text, 1);
  png_write_info(wr->png, wr->info);
  png_write_image(wr->png, wr->rows.data());
  png_write_end(wr->png, nullptr);
  return std::move(wr->bytes);
}

}  // namespace

std::string encode_png(const std::string& path, const Image& img, int bits, double dpi) {
  const int c = img.channels >= 3 ? 3 : 1;
  const double maxv = bits == 8 ? 255.0 : 65535.0;
  const size_t stride = static_cast<size_t>(img.width) * c * (bits / 8);
  std::vector<unsigned char> buf(stride * img.height);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int k = 0; k < c; ++k) {
        const float v = img.at(x, y, k);
        if (!std::isfinite(v)) throw Error(path + ": refusing to write a non-finite value");
        const auto q =
            static_cast<unsigned>(std::lround(std::clamp(static_cast<double>(v), 0.0, 1.0) * maxv));
        unsigned char* p = buf.data() + y * stride + (static_cast<size_t>(x) * c + k) * (bits / 8);
        if (bits == 8) {
          p[0] = static_cast<unsigned char>(q);
        } else {  // PNG is big-endian
          p[0] = static_cast<unsigned char>(q >> 8);
          p[1] = static_cast<unsigned char>(q & 0xFF);
        }
      }
  return png_bytes(path, buf.data(), img.width, img.height, bits, c, stride, dpi, true);
}

std::string encode_rgb8_png(const std::string& path, const uint8_t* rgb, int w, int h) {
  return png_bytes(path, rgb, w, h, 8, 3, static_cast<size_t>(w) * 3, 0, false);
}

std::string encode_mask_png(const std::string& path, const std::vector<uint8_t>& on, int w, int h) {
  if (on.size() != static_cast<size_t>(w) * h)
    throw Error(path + ": mask has " + std::to_string(on.size()) + " entries for " +
                std::to_string(w) + "x" + std::to_string(h) + " pixels");
  std::vector<unsigned char> buf(on.size());
  for (size_t i = 0; i < on.size(); ++i) buf[i] = on[i] ? 255 : 0;
  return png_bytes(path, buf.data(), w, h, 8, 1, static_cast<size_t>(w), 0, false);
}

// ---- JPEG --------------------------------------------------------------------------------------

namespace {

struct JpegError {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char text[JMSG_LENGTH_MAX] = "";
};

[[noreturn]] void jpeg_error_to_jump(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<JpegError*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->text);
  std::longjmp(e->jump, 1);
}

// libjpeg's warnings (a truncated or corrupt file, which it decodes on with grey) are kept, not
// printed: the reader refuses such a file, naming it.
void jpeg_keep_warning(j_common_ptr cinfo, int level) {
  if (level >= 0) return;  // trace messages
  auto* e = reinterpret_cast<JpegError*>(cinfo->err);
  if (e->mgr.num_warnings++ == 0) (*cinfo->err->format_message)(cinfo, e->text);
}

struct JpegRead {
  jpeg_decompress_struct cinfo;
  JpegError err;
  std::vector<unsigned char> row;
  bool created = false;
  ~JpegRead() {
    if (created) jpeg_destroy_decompress(&cinfo);
  }
};

}  // namespace

namespace {

class JpegRows : public CodeRows {
 public:
  JpegRows(const std::string& path, const SizeCheck& check)
      : path_(path), file_(path, "rb"), r_(std::make_unique<JpegRead>()) {
    r_->cinfo.err = jpeg_std_error(&r_->err.mgr);
    r_->err.mgr.error_exit = jpeg_error_to_jump;
    r_->err.mgr.emit_message = jpeg_keep_warning;
    if (setjmp(r_->err.jump)) throw Error(path + ": cannot decode JPEG: " + r_->err.text);
    jpeg_create_decompress(&r_->cinfo);
    r_->created = true;
    jpeg_stdio_src(&r_->cinfo, file_.get());
    jpeg_read_header(&r_->cinfo, TRUE);
    check(r_->cinfo.image_width, r_->cinfo.image_height);
    if (r_->cinfo.jpeg_color_space == JCS_CMYK || r_->cinfo.jpeg_color_space == JCS_YCCK)
      throw Error(path + ": CMYK JPEG is not read (save it as RGB)");
    jpeg_start_decompress(&r_->cinfo);
    width = static_cast<int>(r_->cinfo.output_width);
    height = static_cast<int>(r_->cinfo.output_height);
    channels = r_->cinfo.output_components >= 3 ? 3 : 1;
    bits = 8;
    r_->row.resize(static_cast<size_t>(width) * r_->cinfo.output_components);
    out_.resize(static_cast<size_t>(width) * channels);
  }
  const uint16_t* next() override {
    if (setjmp(r_->err.jump)) throw Error(path_ + ": cannot decode JPEG: " + r_->err.text);
    JSAMPROW p = r_->row.data();
    jpeg_read_scanlines(&r_->cinfo, &p, 1);
    const int in = r_->cinfo.output_components;
    if (in == channels)
      std::copy(r_->row.begin(), r_->row.begin() + out_.size(), out_.begin());
    else
      for (int x = 0; x < width; ++x)
        for (int c = 0; c < channels; ++c) out_[x * channels + c] = r_->row[x * in + c];
    if (r_->cinfo.output_scanline == r_->cinfo.output_height) {
      jpeg_finish_decompress(&r_->cinfo);
      if (r_->err.mgr.num_warnings > 0)
        throw Error(path_ + ": damaged JPEG (" + r_->err.text +
                    "): libjpeg would fill the missing part with grey; copy or export the photo "
                    "again");
    }
    return out_.data();
  }

 private:
  std::string path_;
  File file_;
  std::unique_ptr<JpegRead> r_;
  std::vector<uint16_t> out_;
};

}  // namespace

std::unique_ptr<CodeRows> jpeg_rows(const std::string& path, const SizeCheck& check) {
  return std::make_unique<JpegRows>(path, check);
}

LoadedImage decode_jpeg(const std::string& path, const SizeCheck& check) {
  JpegRows rows(path, check);
  return whole_image(rows);
}

namespace {
struct JpegWrite {
  jpeg_compress_struct cinfo;
  JpegError err;
  unsigned char* mem = nullptr;
  unsigned long size = 0;
  bool created = false;
  ~JpegWrite() {
    if (created) jpeg_destroy_compress(&cinfo);
    std::free(mem);
  }
};
}  // namespace

std::string encode_jpeg(const std::string& path, const Image& srgb, int quality) {
  const int c = srgb.channels >= 3 ? 3 : 1;
  std::vector<unsigned char> row(static_cast<size_t>(srgb.width) * c);
  const auto w = std::make_unique<JpegWrite>();
  w->cinfo.err = jpeg_std_error(&w->err.mgr);
  w->err.mgr.error_exit = jpeg_error_to_jump;
  if (setjmp(w->err.jump)) throw Error(path + ": cannot encode JPEG: " + w->err.text);
  jpeg_create_compress(&w->cinfo);
  w->created = true;
  jpeg_mem_dest(&w->cinfo, &w->mem, &w->size);
  w->cinfo.image_width = static_cast<JDIMENSION>(srgb.width);
  w->cinfo.image_height = static_cast<JDIMENSION>(srgb.height);
  w->cinfo.input_components = c;
  w->cinfo.in_color_space = c == 3 ? JCS_RGB : JCS_GRAYSCALE;
  jpeg_set_defaults(&w->cinfo);
  jpeg_set_quality(&w->cinfo, quality, TRUE);
  jpeg_start_compress(&w->cinfo, TRUE);
  const std::string stamp = output_stamp(path);  // who wrote it, as a comment segment
  jpeg_write_marker(&w->cinfo, JPEG_COM, reinterpret_cast<const JOCTET*>(stamp.data()),
                    static_cast<unsigned>(stamp.size()));
  while (w->cinfo.next_scanline < w->cinfo.image_height) {
    const int y = static_cast<int>(w->cinfo.next_scanline);
    for (int x = 0; x < srgb.width; ++x)
      for (int k = 0; k < c; ++k) {
        const float v = srgb.at(x, y, k);
        if (!std::isfinite(v)) throw Error(path + ": refusing to write a non-finite value");
        row[static_cast<size_t>(x) * c + k] = static_cast<unsigned char>(
            std::lround(std::clamp(static_cast<double>(v), 0.0, 1.0) * 255.0));
      }
    JSAMPROW p = row.data();
    jpeg_write_scanlines(&w->cinfo, &p, 1);
  }
  jpeg_finish_compress(&w->cinfo);
  return std::string(reinterpret_cast<const char*>(w->mem), w->size);
}

// ---- TIFF --------------------------------------------------------------------------------------

namespace {

thread_local std::string t_tiff_message;

void tiff_message(const char* module, const char* fmt, va_list ap) {
  char buf[300];
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  t_tiff_message = buf;
  (void)module;
}
void tiff_quiet(const char*, const char*, va_list) {}

struct TiffRead {
  TIFF* t = nullptr;
  ~TiffRead() {
    if (t) TIFFClose(t);
  }
};

}  // namespace

LoadedImage decode_tiff(const std::string& path, const SizeCheck& check) {
  static const bool handlers = [] {
    TIFFSetErrorHandler(tiff_message);
    TIFFSetWarningHandler(tiff_quiet);
    return true;
  }();
  (void)handlers;
  t_tiff_message.clear();
  TiffRead r;
  r.t = TIFFOpen(path.c_str(), "r");
  if (!r.t) throw Error(path + ": cannot decode TIFF: " + t_tiff_message);
  uint32_t w = 0, h = 0;
  uint16_t spp = 1, bps = 8, format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG;
  TIFFGetField(r.t, TIFFTAG_IMAGEWIDTH, &w);
  TIFFGetField(r.t, TIFFTAG_IMAGELENGTH, &h);
  TIFFGetFieldDefaulted(r.t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(r.t, TIFFTAG_BITSPERSAMPLE, &bps);
  TIFFGetFieldDefaulted(r.t, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(r.t, TIFFTAG_PLANARCONFIG, &planar);
  check(w, h);
  const bool is_float = format == SAMPLEFORMAT_IEEEFP && bps == 32;
  const bool is_uint = format == SAMPLEFORMAT_UINT && (bps == 8 || bps == 16);
  if (!(is_float || is_uint) || spp < 1 || spp > 4)
    throw Error(path + ": TIFF with " + std::to_string(spp) + " samples of " + std::to_string(bps) +
                " bits (format " + std::to_string(format) +
                ") is not read: 8- or 16-bit unsigned, or 32-bit float, 1 to 4 samples");
  if (planar != PLANARCONFIG_CONTIG || TIFFIsTiled(r.t))
    throw Error(path + ": tiled or planar TIFF is not read (save it as stripped, interleaved)");
  LoadedImage out;
  out.bits = is_float ? 0 : bps;
  out.image = new_image(static_cast<int>(w), static_cast<int>(h), spp);
  std::vector<unsigned char> row(TIFFScanlineSize(r.t));
  if (row.size() < static_cast<size_t>(w) * spp * (bps / 8))
    throw Error(path + ": TIFF rows are shorter than their width says");
  for (uint32_t y = 0; y < h; ++y) {
    if (TIFFReadScanline(r.t, row.data(), y) < 0)
      throw Error(path + ": cannot decode TIFF row " + std::to_string(y) + ": " + t_tiff_message);
    if (is_float)
      put_row(reinterpret_cast<const float*>(row.data()), w, spp, 1.0, y, &out.image);
    else if (bps == 16)
      put_row(reinterpret_cast<const uint16_t*>(row.data()), w, spp, 1.0 / 65535, y, &out.image);
    else
      put_row(row.data(), w, spp, 1.0 / 255, y, &out.image);
  }
  return out;
}

}  // namespace aniso
