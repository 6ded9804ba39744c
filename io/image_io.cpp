#include "io/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/color.h"
#include "core/error.h"
#include "io/files.h"
#include "io/image_codecs.h"

namespace aniso {

namespace {

// The size a header declares, checked before a single pixel is allocated: a forged header must
// not make the reader ask for gigabytes.
void check_declared_size(const std::string& path, long long w, long long h, int expect_w,
                         int expect_h) {
  if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide || w * h > kMaxImagePixels)
    throw Error(path + ": declared size " + std::to_string(w) + "x" + std::to_string(h) +
                " is outside the limits (sides up to " + std::to_string(kMaxImageSide) + ", " +
                std::to_string(kMaxImagePixels) + " pixels)");
  if (expect_w > 0 && (w != expect_w || h != expect_h))
    throw Error(path + ": is " + std::to_string(w) + "x" + std::to_string(h) + ", expected " +
                std::to_string(expect_w) + "x" + std::to_string(expect_h));
}

Image read_exr(const std::string& path, int expect_w, int expect_h) {
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    check_declared_size(path, static_cast<long long>(dw.max.x) - dw.min.x + 1,
                        static_cast<long long>(dw.max.y) - dw.min.y + 1, expect_w, expect_h);
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    const Imf::ChannelList& cl = file.header().channels();
    std::vector<const char*> names;
    if (cl.findChannel("R")) {
      names.push_back("R");
      if (cl.findChannel("G")) names.push_back("G");
      if (cl.findChannel("B") && names.size() == 2) names.push_back("B");
      if (cl.findChannel("B") && names.size() == 1)
        throw Error(path + ": EXR has channels R and B but no G");
    } else if (cl.findChannel("Y")) {
      names.push_back("Y");
    } else {
      throw Error(path + ": EXR has no R or Y channel");
    }
    Image img(w, h, static_cast<int>(names.size()));
    const size_t xs = sizeof(float) * img.channels, ys = xs * w;
    char* base = reinterpret_cast<char*>(img.px.data()) - dw.min.x * xs - dw.min.y * ys;
    Imf::FrameBuffer fb;
    for (size_t c = 0; c < names.size(); ++c)
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot read EXR: " + e.what());
  }
}

std::atomic<int> g_compression{static_cast<int>(Imf::ZIP_COMPRESSION)};

}  // namespace

void set_exr_compression(const std::string& name) {
  if (name == "zip")
    g_compression = Imf::ZIP_COMPRESSION;
  else if (name == "piz")
    g_compression = Imf::PIZ_COMPRESSION;
  else if (name == "none")
    g_compression = Imf::NO_COMPRESSION;
  else
    throw Error("EXR compression must be zip, piz or none (got '" + name + "')");
}

LoadedImage read_image(const std::string& path, int expect_w, int expect_h) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(st)) throw Error(path + ": file not found");
  if (!std::filesystem::is_regular_file(st))
    throw Error(path + ": not a regular file (a folder, device or FIFO is not read)");
  LoadedImage out;
  if (lower_ext(path) == ".exr") {
    out.image = read_exr(path, expect_w, expect_h);
    return out;
  }
  const SizeCheck check = [&](long long w, long long h) {
    check_declared_size(path, w, h, expect_w, expect_h);
  };
  switch (sniff_image(path)) {
    case ImageKind::kPng:
      return decode_png(path, check);
    case ImageKind::kJpeg:
      return decode_jpeg(path, check);
    case ImageKind::kTiff:
      return decode_tiff(path, check);
    case ImageKind::kOther:
      break;
  }
  throw Error(path + ": cannot decode image (not PNG/TIFF/JPEG/EXR?)");
}

void write_exr(const std::string& path, const Image& img) {
  if (img.channels < 1 || img.channels > 3) throw Error(path + ": EXR writer takes 1-3 channels");
  for (float v : img.px)
    if (!std::isfinite(v)) throw Error(path + ": refusing to write a non-finite value");
  write_atomically(path, [&](const std::string& tmp) {
    try {
      static const char* kNames[] = {"R", "G", "B"};
      Imf::Header header(img.width, img.height);
      // zlib level 1: within a few % of the default's size on float buffers, several times faster.
      constexpr int kZipLevel = 1;
      header.zipCompressionLevel() = kZipLevel;
      header.compression() = static_cast<Imf::Compression>(g_compression.load());
      for (int c = 0; c < img.channels; ++c)
        header.channels().insert(kNames[c], Imf::Channel(Imf::FLOAT));
      Imf::OutputFile file(tmp.c_str(), header);
      Imf::FrameBuffer fb;
      const size_t xs = sizeof(float) * img.channels, ys = xs * img.width;
      char* base = const_cast<char*>(reinterpret_cast<const char*>(img.px.data()));
      for (int c = 0; c < img.channels; ++c)
        fb.insert(kNames[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
      file.setFrameBuffer(fb);
      file.writePixels(img.height);
    } catch (const std::exception& e) {
      throw Error(path + ": cannot write EXR: " + e.what());
    }
  });
}

void write_png(const std::string& path, const Image& img, int bits) {
  write_png(path, img, bits, 0);
}

void write_png(const std::string& path, const Image& img, int bits, double dpi) {
  if (bits != 8 && bits != 16) throw Error(path + ": PNG bit depth must be 8 or 16");
  write_text_file(path, encode_png(path, img, bits, dpi));
}

Image encode_srgb(const Image& linear, double exposure) {
  Image out = linear;
  for (float& v : out.px) v = static_cast<float>(srgb_encode(v * exposure));
  return out;
}

}  // namespace aniso
