// io/ internal: PNG, JPEG and TIFF through libpng, libjpeg-turbo and libtiff directly. OpenCV's
// imgcodecs links about 140 libraries (GDAL among them), and every process linked to it pays their
// loading at start, more than a whole small fit takes.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "io/images/image_io.h"

namespace aniso {

// Called with the declared size before any pixel is allocated; throws to refuse it.
using SizeCheck = std::function<void(long long w, long long h)>;

enum class ImageKind { kPng, kJpeg, kTiff, kOther };
// From the file's first bytes (the extension is not trusted).
ImageKind sniff_image(const std::string& path);

// The stored codes scaled to [0, 1] (8 or 16 bit) or as they are (float TIFF); RGB from the first
// three channels, grey from the first of one or two; alpha dropped.
LoadedImage decode_png(const std::string& path, const SizeCheck& check);
LoadedImage decode_jpeg(const std::string& path, const SizeCheck& check);
LoadedImage decode_tiff(const std::string& path, const SizeCheck& check);
// The same as rows of codes (io/images/image_io.h CodeRows), the file opened and its header read
// and checked at once.
std::unique_ptr<CodeRows> png_rows(const std::string& path, const SizeCheck& check);
std::unique_ptr<CodeRows> jpeg_rows(const std::string& path, const SizeCheck& check);

// PNG file bytes of values in [0, 1] (8 or 16 bit; 1 or 3 channels), with a pHYs chunk when
// dpi > 0. `path` names the file in messages.
std::string encode_png(const std::string& path, const Image& img, int bits, double dpi);
// Baseline JPEG bytes of an image already in sRGB (values 0..1), at `quality` (1-100).
std::string encode_jpeg(const std::string& path, const Image& srgb, int quality);
// An 8-bit RGB PNG of bytes as they are (w x h pixels, row by row), unfiltered, zlib level 1: a
// picture written for a person to look at, fast.
std::string encode_rgb8_png(const std::string& path, const uint8_t* rgb, int w, int h);
// An 8-bit grey PNG of a mask: 255 where `on` is non-zero, else 0 (w x h entries, row by row).
std::string encode_mask_png(const std::string& path, const std::vector<uint8_t>& on, int w, int h);

}  // namespace aniso
