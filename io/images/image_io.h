// Image files: OpenEXR (half or float) through OpenEXR; PNG/TIFF/JPEG through libpng, libjpeg and
// libtiff (io/images/image_codecs.h).
// Reading returns the stored values: EXR as they are, integer images scaled to [0, 1] with no
// colour decoding (the capture reader applies `color.encoding`). Channels come back as R,G,B
// (or one grey channel, or R,G for two-channel buffers); alpha is dropped.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/image.h"
#include "io/files/files.h"
#include "io/images/exr_compression.h"

namespace aniso {

struct LoadedImage {
  Image image;
  int bits = 0;  // 0 for float data, else 8 or 16
};

// Limits checked against an image's declared size before its pixels are allocated.
inline constexpr long long kMaxImageSide = 65536;
inline constexpr long long kMaxImagePixels = 1LL << 26;  // 8192 x 8192

// Reads an image; with expect_w > 0 its declared size must be expect_w x expect_h (checked
// before decoding). With `rows` (one entry per row of the image), an uncompressed float EXR has
// only the rows whose entry is non-zero read from its file and decoded, the others 0 (a capture's
// rows without a sample pixel); every other file is read whole. `zero_others` false: the rows not
// asked for are not written at all (a reused allocation's old values; for a reader that reads a
// band of rows file after file and looks at nothing else, where zeroing the rest cost more than
// the read).
LoadedImage read_image(const std::string& path, int expect_w = 0, int expect_h = 0,
                       const std::vector<uint8_t>* rows = nullptr, bool zero_others = true);

// An 8- or 16-bit PNG or JPEG read one row at a time as its stored codes (RGB or grey; alpha
// dropped), so that a reader that merges several images row by row never holds them whole.
class CodeRows {
 public:
  virtual ~CodeRows() = default;
  int width = 0, height = 0, channels = 0, bits = 0;  // channels: 1 or 3; bits: 8 or 16
  // The next row: width * channels codes, valid until the next call. Throws naming the file
  // where it is damaged.
  virtual const uint16_t* next() = 0;
};

// The file's rows as codes where it is an integer PNG or JPEG (checked and size-limited as
// read_image does); nullptr for any other kind (EXR, TIFF), to be read with read_image.
std::unique_ptr<CodeRows> read_image_rows(const std::string& path);

// An image's declared width and height, read from its header (nothing decoded); throws naming the
// file as read_image does.
void image_dimensions(const std::string& path, int* w, int* h);

// The bytes of an uncompressed float EXR (scanline, channels R[,G[,B]]), written by hand: what
// write_exr writes with compression "none". Handed to `sink` in pieces of at most ~64 KiB
// after the header (a reused buffer: no fresh pages for a copy of the file).
// `software`: the header's "software" attribute (who wrote the file: io/files/files.h
// output_stamp).
void encode_exr_uncompressed(const Image& img, const ByteSink& sink,
                             const std::string& software = "aniso");

// Decodes the bytes of an uncompressed single-part scanline EXR whose channels are all 32-bit
// float into *out (channels as read_image gives them; out's allocation, if any, is reused); false
// for anything else (compressed, half, tiled, several parts, a malformed offset or block), which
// read_image hands to OpenEXR (*out may then have lost its allocation). Throws only on a declared
// size outside the limits or not the expected one.
// With `rows` (one per row of the display window), only the rows whose entry is non-zero are
// decoded, and only their blocks are read from `bytes` (the others 0, or with `zero_others`
// false not written).
bool decode_exr_uncompressed(const std::string& bytes, const std::string& path, int expect_w,
                             int expect_h, Image* out, const std::vector<uint8_t>* rows = nullptr,
                             bool zero_others = true);

// While one is alive, uncompressed EXRs are decoded into the allocations of images given back
// (and, where a file cannot be mapped, io/files/mapped_file.h, read through one buffer per thread,
// reused file after file). A 2048^2 RGB view is 48 MB, above glibc's largest mmap threshold (32
// MB): every fresh buffer for it was new pages the kernel zeroes first. The loader of a capture set
// holds one while it decodes views and gives back each view's image when its records are written;
// the buffers go with it. One at a time (a second one while the first is alive does nothing), and
// every read it serves ends before it does.
class ExrReadBuffers {
 public:
  ExrReadBuffers();
  ~ExrReadBuffers();
  void give_back(Image&& img);  // its allocation, for a later read
  ExrReadBuffers(const ExrReadBuffers&) = delete;
  ExrReadBuffers& operator=(const ExrReadBuffers&) = delete;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// An image's allocation handed to the ExrReadBuffers alive, if one is (else freed with it): for
// images whose owner cannot reach the loader's, such as a band's rows of a view's geometry.
void give_back_to_read_buffers(Image&& img);

// Float EXR with channels R[,G[,B]] (1, 2 or 3 channels), compressed as `c`. Written atomically.
void write_exr(const std::string& path, const Image& img, ExrCompression c = ExrCompression::kZip);

// 8- or 16-bit PNG of values clamped to [0, 1] (already encoded by the caller). Written atomically.
void write_png(const std::string& path, const Image& img, int bits);
// ... recording the print resolution (a pHYs chunk), so it prints at the intended size.
void write_png(const std::string& path, const Image& img, int bits, double dpi);

// An 8-bit grey PNG mask: 255 where `on` is non-zero, else 0 (w x h, row by row). Unfiltered,
// run-length deflated (libpng's adaptive filters buy a mask nothing and cost most of its time).
// An 8-bit baseline JPEG of an image already in sRGB (values 0..1).
void write_jpeg(const std::string& path, const Image& srgb, int quality = 92);
void write_mask_png(const std::string& path, const std::vector<uint8_t>& on, int w, int h);
// 8-bit RGB bytes (w x h pixels, row by row) as a PNG, written atomically.
void write_rgb8_png(const std::string& path, const std::vector<uint8_t>& rgb, int w, int h);

// Linear radiance times `exposure`, clamped to [0, 1] and sRGB-encoded (for 8-bit previews).
Image encode_srgb(const Image& linear, double exposure);

}  // namespace aniso
