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
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/color.h"
#include "core/error.h"
#include "io/files.h"

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

// A PNG's size from its IHDR chunk (bytes 16-23, big-endian), or false if not a PNG.
bool png_size(const std::string& path, long long* w, long long* h) {
  unsigned char b[24];
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  const size_t n = std::fread(b, 1, sizeof b, f);
  std::fclose(f);
  static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n < 24 || std::memcmp(b, sig, 8) != 0) return false;
  auto be = [&](int o) {
    return (static_cast<long long>(b[o]) << 24) | (b[o + 1] << 16) | (b[o + 2] << 8) | b[o + 3];
  };
  *w = be(16);
  *h = be(20);
  return true;
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
  long long pw = 0, ph = 0;
  if (png_size(path, &pw, &ph)) check_declared_size(path, pw, ph, expect_w, expect_h);
  cv::Mat m;
  try {
    m = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw Error(path + ": cannot decode image: " + e.what());
  }
  if (m.empty()) throw Error(path + ": cannot decode image (not PNG/TIFF/JPEG/EXR?)");
  double scale = 1.0;
  switch (m.depth()) {
    case CV_8U:
      out.bits = 8;
      scale = 1.0 / 255.0;
      break;
    case CV_16U:
      out.bits = 16;
      scale = 1.0 / 65535.0;
      break;
    case CV_32F:
    case CV_64F:
      out.bits = 0;
      break;
    default:
      throw Error(path + ": unsupported pixel depth");
  }
  const int c_in = m.channels();
  const int c_out = c_in >= 3 ? 3 : 1;
  cv::Mat f;
  m.convertTo(f, CV_MAKETYPE(CV_32F, c_in), scale);
  Image img(f.cols, f.rows, c_out);
  for (int y = 0; y < f.rows; ++y) {
    const float* row = f.ptr<float>(y);
    for (int x = 0; x < f.cols; ++x) {
      if (c_out == 1) {
        img.at(x, y, 0) = row[x * c_in];
      } else {  // OpenCV stores BGR(A)
        img.at(x, y, 0) = row[x * c_in + 2];
        img.at(x, y, 1) = row[x * c_in + 1];
        img.at(x, y, 2) = row[x * c_in + 0];
      }
    }
  }
  out.image = std::move(img);
  return out;
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

namespace {

uint32_t png_crc(const uint8_t* data, size_t n, uint32_t crc = 0xFFFFFFFFu) {
  for (size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc;
}

// A pHYs chunk (pixels per metre) right after IHDR, so a printer prints at the intended size.
void insert_phys(std::vector<uchar>* png, double dpi) {
  const uint32_t ppm = static_cast<uint32_t>(std::lround(dpi / 0.0254));
  std::vector<uint8_t> c = {0, 0, 0, 9, 'p', 'H', 'Y', 's'};
  for (int rep = 0; rep < 2; ++rep)
    for (int k = 3; k >= 0; --k) c.push_back(static_cast<uint8_t>(ppm >> (8 * k)));
  c.push_back(1);  // unit: metre
  const uint32_t crc = png_crc(c.data() + 4, c.size() - 4) ^ 0xFFFFFFFFu;
  for (int k = 3; k >= 0; --k) c.push_back(static_cast<uint8_t>(crc >> (8 * k)));
  constexpr size_t kAfterIhdr = 8 + 4 + 4 + 13 + 4;
  png->insert(png->begin() + kAfterIhdr, c.begin(), c.end());
}

}  // namespace

void write_png(const std::string& path, const Image& img, int bits) {
  write_png(path, img, bits, 0);
}

void write_png(const std::string& path, const Image& img, int bits, double dpi) {
  if (bits != 8 && bits != 16) throw Error(path + ": PNG bit depth must be 8 or 16");
  const int c = img.channels >= 3 ? 3 : 1;
  const double maxv = bits == 8 ? 255.0 : 65535.0;
  cv::Mat m(img.height, img.width, CV_MAKETYPE(bits == 8 ? CV_8U : CV_16U, c));
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int k = 0; k < c; ++k) {
        float v = img.at(x, y, c == 3 ? 2 - k : 0);  // RGB -> BGR
        if (!std::isfinite(v)) throw Error(path + ": refusing to write a non-finite value");
        const double q = std::round(std::clamp(static_cast<double>(v), 0.0, 1.0) * maxv);
        if (bits == 8)
          m.ptr<uint8_t>(y)[x * c + k] = static_cast<uint8_t>(q);
        else
          m.ptr<uint16_t>(y)[x * c + k] = static_cast<uint16_t>(q);
      }
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", m, bytes)) throw Error(path + ": cannot encode PNG");
  if (dpi > 0) insert_phys(&bytes, dpi);
  write_text_file(path, std::string(bytes.begin(), bytes.end()));
}

Image encode_srgb(const Image& linear, double exposure) {
  Image out = linear;
  for (float& v : out.px) v = static_cast<float>(srgb_encode(v * exposure));
  return out;
}

}  // namespace aniso
