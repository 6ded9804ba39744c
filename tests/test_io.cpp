// File formats (docs/formats.md): images, capture sets, materials and sample tables round-trip; the
// readers decode what others may write (PNG with sRGB, OBJ meshes).
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cstdio>
// clang-format off
#include <jpeglib.h>  // after cstdio: it needs FILE
#include <png.h>
// clang-format on

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <half.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/files/files.h"
#include "io/files/mapped_file.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "io/formats/table.h"
#include "io/images/image_io.h"
#include "test_util.h"

namespace aniso {
namespace {

TEST(ImageIO, ExrRoundTripIsExact) {
  const std::string dir = test::tmp_dir("img");
  Image a(7, 5, 3);
  for (size_t i = 0; i < a.px.size(); ++i) a.px[i] = 0.001f * i - 0.05f;
  write_exr(dir + "/a.exr", a);
  const LoadedImage b = read_image(dir + "/a.exr");
  ASSERT_EQ(b.image.width, 7);
  ASSERT_EQ(b.image.channels, 3);
  EXPECT_EQ(b.bits, 0);
  EXPECT_EQ(a.px, b.image.px);
}

// An EXR's float channels `names`, interleaved, as OpenEXR itself reads them (the independent
// reader for our own encoder and decoder).
// OpenEXR's values of a file whose data window lies inside its display window, placed in the
// display window (zeros around the data window).
std::vector<float> openexr_pixels(const std::string& path, const std::vector<const char*>& names) {
  Imf::InputFile in(path.c_str());
  const Imath::Box2i dw = in.header().dataWindow(), disp = in.header().displayWindow();
  const size_t w = disp.max.x - disp.min.x + 1, h = disp.max.y - disp.min.y + 1, c = names.size();
  std::vector<float> px(w * h * c);
  char* base = reinterpret_cast<char*>(px.data()) -
               (static_cast<long>(disp.min.x) + static_cast<long>(disp.min.y) * long(w)) * c * 4;
  Imf::FrameBuffer fb;
  for (size_t k = 0; k < c; ++k)
    fb.insert(names[k], Imf::Slice(Imf::FLOAT, base + k * 4, c * 4, c * 4 * w));
  in.setFrameBuffer(fb);
  in.readPixels(dw.min.y, dw.max.y);
  return px;
}

// Compression "none" is our own writer (io/images/image_io.cpp, at memory speed): OpenEXR's reader
// takes its files, header and values, for 1, 2 and 3 channels and odd sizes, exactly as the values
// OpenEXR's own writer stored (zip).
TEST(ImageIO, UncompressedExrFromOurWriterReadsBackThroughOpenExr) {
  const std::string dir = test::tmp_dir("img");
  for (int channels = 1; channels <= 3; ++channels) {
    Image a(37, 23, channels);
    for (size_t i = 0; i < a.px.size(); ++i) a.px[i] = std::sin(0.37 * i) * 1e3f - 0.5f;
    const std::string ours = dir + "/ours" + std::to_string(channels) + ".exr";
    const std::string theirs = dir + "/theirs" + std::to_string(channels) + ".exr";
    write_exr(ours, a, ExrCompression::kNone);
    write_exr(theirs, a);
    Imf::InputFile in(ours.c_str());
    EXPECT_EQ(in.header().compression(), Imf::NO_COMPRESSION);
    EXPECT_EQ(in.header().dataWindow().max.x, 36);
    EXPECT_EQ(in.header().dataWindow().max.y, 22);
    int n = 0;
    for (auto c = in.header().channels().begin(); c != in.header().channels().end(); ++c, ++n)
      EXPECT_EQ(c.channel().type, Imf::FLOAT);
    EXPECT_EQ(n, channels);
    std::vector<const char*> names({"R", "G", "B"});
    names.resize(channels);
    EXPECT_EQ(openexr_pixels(ours, names), a.px) << channels << " channel(s)";
    const LoadedImage b = read_image(ours), c = read_image(theirs);
    ASSERT_EQ(b.image.channels, channels);
    EXPECT_EQ(a.px, b.image.px) << channels << " channel(s)";
    EXPECT_EQ(c.image.px, b.image.px);
  }
}

// Through the loader's reused per-thread buffer and images given back, files of different sizes
// read as they do without them (a larger one, then a smaller one and a damaged one in the same
// buffers); a second scope while one is alive reads without buffers of its own.
TEST(ImageIO, ReusedReadBuffersReadEveryFileAsAFreshOne) {
  const std::string dir = test::tmp_dir("img");
  Image big(61, 40, 3), small(9, 7, 1);
  for (size_t i = 0; i < big.px.size(); ++i) big.px[i] = std::cos(0.1 * i);
  for (size_t i = 0; i < small.px.size(); ++i) small.px[i] = -0.5f * i;
  write_exr(dir + "/big.exr", big, ExrCompression::kNone);
  write_exr(dir + "/small.exr", small, ExrCompression::kNone);
  write_text_file(dir + "/cut.exr", read_text_file(dir + "/big.exr").substr(0, 3000));
  ExrReadBuffers outer;
  const ExrReadBuffers inner;  // refused quietly: the outer one stays in use
  for (int round = 0; round < 2; ++round) {
    LoadedImage b = read_image(dir + "/big.exr");
    EXPECT_EQ(b.image.px, big.px) << round;
    outer.give_back(std::move(b.image));  // the small one is decoded into its allocation
    LoadedImage s = read_image(dir + "/small.exr");
    EXPECT_TRUE(s.image.width == 9 && s.image.channels == 1) << round;
    EXPECT_EQ(s.image.px, small.px) << round;
    outer.give_back(std::move(s.image));  // and the big one into the small one's
    EXPECT_THROW(read_image(dir + "/cut.exr"), Error) << round;
  }
}

// Uncompressed float EXRs are read by our own decoder (at memory speed): files OpenEXR wrote
// without compression, with an alpha channel, a data window away from the origin inside a larger
// display window (the image is the display window) and decreasing line order, decode to exactly
// OpenEXR's values; half, compressed and damaged files are left to
// OpenEXR (false), and a damaged file still gets an error naming it.
TEST(ImageIO, UncompressedExrDecodesAsOpenExrReadsIt) {
  const std::string dir = test::tmp_dir("img");
  auto write = [&](const std::string& path, Imf::Compression comp, Imf::PixelType type,
                   Imf::LineOrder order) {
    const int w = 19, h = 11;
    Imf::Header header(Imath::Box2i({0, 0}, {w + 9, h + 9}), Imath::Box2i({5, 7}, {w + 4, h + 6}));
    header.compression() = comp;
    header.lineOrder() = order;
    std::vector<float> px(static_cast<size_t>(w) * h * 4);
    for (size_t i = 0; i < px.size(); ++i) px[i] = std::cos(0.11f * i) * 3.f;
    std::vector<Imath::half> halves(px.begin(), px.end());
    const size_t size = type == Imf::HALF ? 2 : 4;
    Imf::FrameBuffer fb;
    char* base = (type == Imf::HALF ? reinterpret_cast<char*>(halves.data())
                                    : reinterpret_cast<char*>(px.data())) -
                 (5 + 7 * w) * 4 * size;
    for (int k = 0; k < 4; ++k) {
      const char* n = k == 0 ? "R" : k == 1 ? "G" : k == 2 ? "B" : "A";
      header.channels().insert(n, Imf::Channel(type));
      fb.insert(n, Imf::Slice(type, base + size * k, 4 * size, 4 * size * w));
    }
    Imf::OutputFile out(path.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(h);
  };
  for (Imf::LineOrder order : {Imf::INCREASING_Y, Imf::DECREASING_Y}) {
    const std::string path = dir + "/plain" + std::to_string(int(order)) + ".exr";
    write(path, Imf::NO_COMPRESSION, Imf::FLOAT, order);
    Image ours;
    ASSERT_TRUE(decode_exr_uncompressed(read_text_file(path), path, 0, 0, &ours));
    EXPECT_EQ(ours.width, 29);
    EXPECT_EQ(ours.height, 21);
    EXPECT_EQ(ours.at(4, 7, 0), 0.f);  // left of the data window
    EXPECT_EQ(ours.at(5, 7, 0), 3.f);  // its first value, cos 0 * 3
    EXPECT_EQ(ours.channels, 3);
    EXPECT_EQ(ours.px, openexr_pixels(path, {"R", "G", "B"}));
    EXPECT_EQ(read_image(path).image.px, ours.px);
    EXPECT_THROW(decode_exr_uncompressed(read_text_file(path), path, 20, 11, &ours), Error);
    // Damaged: cut inside the pixels, or a block's line number outside the window.
    std::string bytes = read_text_file(path);
    EXPECT_FALSE(decode_exr_uncompressed(bytes.substr(0, bytes.size() - 5), path, 0, 0, &ours));
    write_text_file(dir + "/cut.exr", bytes.substr(0, bytes.size() - 5));
    EXPECT_THROW(read_image(dir + "/cut.exr"), Error);
  }
  const std::string half = dir + "/half.exr", zip = dir + "/zip.exr";
  write(half, Imf::NO_COMPRESSION, Imf::HALF, Imf::INCREASING_Y);
  write(zip, Imf::ZIP_COMPRESSION, Imf::FLOAT, Imf::INCREASING_Y);
  Image img;
  EXPECT_FALSE(decode_exr_uncompressed(read_text_file(half), half, 0, 0, &img));
  EXPECT_FALSE(decode_exr_uncompressed(read_text_file(zip), zip, 0, 0, &img));
  EXPECT_EQ(read_image(zip).image.px, openexr_pixels(zip, {"R", "G", "B"}));
  EXPECT_EQ(read_image(half).image.px, openexr_pixels(half, {"R", "G", "B"}));
}

// A data window inside or reaching past the display window (as other tools write: a crop to the
// object, an overscan): the image is the display window, zeros where there is no data, the data
// window's values in place, read by our decoder (uncompressed) and through OpenEXR (zip) alike.
// They were read as the data window alone, so a cropped geometry buffer lost its registration.
TEST(ImageIO, ADataWindowIsPlacedInItsDisplayWindow) {
  const std::string dir = test::tmp_dir("img");
  // Display window (0, 0)..(5, 3); data windows inside it and reaching past it on three sides.
  for (const Imath::Box2i& data : {Imath::Box2i({1, 1}, {3, 2}), Imath::Box2i({-2, 1}, {4, 6})})
    for (Imf::Compression comp : {Imf::NO_COMPRESSION, Imf::ZIP_COMPRESSION}) {
      const std::string path = dir + "/window.exr";
      Imf::Header header(Imath::Box2i({0, 0}, {5, 3}), data);
      header.compression() = comp;
      header.channels().insert("R", Imf::Channel(Imf::FLOAT));
      const int w = data.max.x - data.min.x + 1, h = data.max.y - data.min.y + 1;
      std::vector<float> px(static_cast<size_t>(w) * h);
      for (size_t i = 0; i < px.size(); ++i) px[i] = float(i + 1);
      Imf::FrameBuffer fb;
      fb.insert("R", Imf::Slice(Imf::FLOAT,
                                reinterpret_cast<char*>(px.data()) -
                                    (data.min.x + static_cast<long>(data.min.y) * w) * 4,
                                4, 4 * w));
      {
        Imf::OutputFile out(path.c_str(), header);
        out.setFrameBuffer(fb);
        out.writePixels(h);
      }
      Image ours;
      EXPECT_EQ(decode_exr_uncompressed(read_text_file(path), path, 6, 4, &ours),
                comp == Imf::NO_COMPRESSION);
      const Image r = read_image(path, 6, 4).image;
      ASSERT_EQ(r.width, 6);
      ASSERT_EQ(r.height, 4);
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 6; ++x) {
          const bool in = data.intersects(Imath::V2i(x, y));
          EXPECT_EQ(r.at(x, y, 0),
                    in ? px[(y - data.min.y) * static_cast<size_t>(w) + x - data.min.x] : 0.f)
              << x << " " << y;
        }
      if (comp == Imf::NO_COMPRESSION) {
        EXPECT_EQ(ours.px, r.px);
      }
    }
}

// A capture's image read by rows (read_image's `rows`, what load_view asks for: the rows holding a
// sample pixel): the rows asked for hold the file's values, the others 0, for our writer's files
// and OpenEXR's in decreasing line order with a data window inside the display window; a damaged
// block in a row not asked for is not read; a compressed file is read whole, as without rows.
TEST(ImageIO, OnlyTheRowsAskedForAreRead) {
  const std::string dir = test::tmp_dir("img");
  Image a(23, 17, 3);
  for (size_t i = 0; i < a.px.size(); ++i) a.px[i] = 0.5f + std::sin(0.13f * i);
  std::vector<uint8_t> rows(17, 0);
  for (int y : {0, 3, 4, 5, 11, 16}) rows[y] = 1;
  auto expect_rows = [&](const Image& want, const Image& got, const std::string& what) {
    ASSERT_EQ(got.width, want.width) << what;
    ASSERT_EQ(got.height, want.height) << what;
    for (int y = 0; y < want.height; ++y)
      for (int x = 0; x < want.width; ++x)
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(got.at(x, y, c), rows[y] ? want.at(x, y, c) : 0.f) << what << x << " " << y;
  };
  write_exr(dir + "/ours.exr", a, ExrCompression::kNone);
  expect_rows(a, read_image(dir + "/ours.exr", 23, 17, &rows).image, "ours");
  {  // into an allocation given back holding the whole image: the rows not asked for are 0 again
    ExrReadBuffers buffers;
    buffers.give_back(read_image(dir + "/ours.exr").image);
    expect_rows(a, read_image(dir + "/ours.exr", 23, 17, &rows).image, "reused");
  }
  // Row 8's block damaged (its y field): not asked for, not read; asked for, the file is read
  // whole and refused as before (OpenEXR names it).
  std::string bytes = read_text_file(dir + "/ours.exr");
  uint64_t at8 = 0;
  const size_t table = bytes.size() - 17 * (8 + 23 * 3 * 4) - 17 * 8;
  std::memcpy(&at8, bytes.data() + table + 8 * 8, 8);
  bytes[at8] = 99;
  write_text_file(dir + "/damaged.exr", bytes);
  expect_rows(a, read_image(dir + "/damaged.exr", 23, 17, &rows).image, "damaged, row 8 not read");
  std::vector<uint8_t> with8 = rows;
  with8[8] = 1;
  EXPECT_THROW(read_image(dir + "/damaged.exr", 23, 17, &with8), Error);
  // OpenEXR's file: decreasing line order, data window (2, 1)..(20, 15) inside 23 x 17.
  for (Imf::Compression comp : {Imf::NO_COMPRESSION, Imf::ZIP_COMPRESSION}) {
    const std::string path = dir + "/theirs.exr";
    Imf::Header header(Imath::Box2i({0, 0}, {22, 16}), Imath::Box2i({2, 1}, {20, 15}));
    header.compression() = comp;
    header.lineOrder() = Imf::DECREASING_Y;
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(a.px.data());
    for (int c = 0; c < 3; ++c) {
      const char* n = c == 0 ? "R" : c == 1 ? "G" : "B";
      header.channels().insert(n, Imf::Channel(Imf::FLOAT));
      fb.insert(n, Imf::Slice(Imf::FLOAT, base + 4 * c, 12, 12 * 23));
    }
    {
      Imf::OutputFile out(path.c_str(), header);
      out.setFrameBuffer(fb);
      out.writePixels(15);
    }
    Image want = a;  // the data window's values, zeros around it
    for (int y = 0; y < 17; ++y)
      for (int x = 0; x < 23; ++x)
        for (int c = 0; c < 3; ++c)
          if (x < 2 || x > 20 || y < 1 || y > 15) want.at(x, y, c) = 0.f;
    const Image got = read_image(path, 23, 17, &rows).image;
    if (comp == Imf::NO_COMPRESSION) {
      expect_rows(want, got, "theirs");
    } else {
      EXPECT_EQ(got.px, want.px);  // read whole
    }
  }
}

// Uncompressed EXRs are read through a mapping of the file (io/files/mapped_file.h). A file another
// program shortens meanwhile would stop the process with "Bus error" on reading past its new end:
// it is an error naming the file instead, exit status 1.
TEST(ImageIO, AMappedFileThatGetsShorterIsAnErrorNamingIt) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const std::string dir = test::tmp_dir("mapped");
  const std::string path = dir + "/view.exr";
  write_text_file(path, std::string(1 << 20, 'x'));
  EXPECT_EXIT(
      {
        MappedFile m(path, 1 << 20);
        if (m.empty()) std::_Exit(3);
        if (::truncate(path.c_str(), 0) != 0) std::_Exit(4);
        volatile char c = m.bytes()[600000];
        (void)c;
        std::_Exit(5);
      },
      ::testing::ExitedWithCode(1), "view.exr: the file got shorter while it was being read");
  // A SIGBUS that is not a fault in the mapping goes to the action before the handler's, not
  // reported as the file's (exit 1): the default ends the process by the signal; a sanitizer that
  // handles SIGBUS itself reports it and aborts.
  EXPECT_EXIT(
      {
        write_text_file(path, std::string(1 << 20, 'x'));
        MappedFile m(path, 1 << 20);
        if (m.empty()) std::_Exit(3);
        ::raise(SIGBUS);
        std::_Exit(5);
      },
      [](int status) { return WIFSIGNALED(status); }, "");
  // A size other than the caller's, or no file: empty (read another way), nothing mapped.
  write_text_file(path, std::string(1000, 'x'));
  EXPECT_TRUE(MappedFile(path, 999).empty());
  EXPECT_FALSE(MappedFile(path, 1000).empty());
  EXPECT_TRUE(MappedFile(dir + "/none.exr", 1000).empty());
}

TEST(ImageIO, Png16RoundTripWithinHalfAStep) {
  const std::string dir = test::tmp_dir("img");
  Image a(9, 4, 3);
  for (size_t i = 0; i < a.px.size(); ++i) a.px[i] = float(i) / a.px.size();
  write_png(dir + "/a.png", a, 16);
  const LoadedImage b = read_image(dir + "/a.png");
  EXPECT_EQ(b.bits, 16);
  for (size_t i = 0; i < a.px.size(); ++i) EXPECT_NEAR(a.px[i], b.image.px[i], 0.5 / 65535 + 1e-7);
}

// TIFF as libtiff writes it (not ours), read back through io/image_codecs: 8- and 16-bit and
// float, LZW-compressed, exact.
TEST(ImageIO, TiffFromLibtiffDecodesExactly) {
  const std::string dir = test::tmp_dir("tiff");
  const int w = 19, h = 7;
  auto code = [](int x, int y, int c) { return (x * 37 + y * 11 + c * 5) % 256; };
  for (int bits : {8, 16, 32}) {
    const std::string path = dir + "/t" + std::to_string(bits) + ".tif";
    TIFF* t = TIFFOpen(path.c_str(), "w");
    ASSERT_NE(t, nullptr);
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, w);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, h);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 3);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, bits);
    TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, bits == 32 ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_RGB);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_LZW);
    std::vector<unsigned char> row(static_cast<size_t>(w) * 3 * (bits / 8));
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const size_t i = static_cast<size_t>(x) * 3 + c;
          if (bits == 8) row[i] = static_cast<unsigned char>(code(x, y, c));
          if (bits == 16) reinterpret_cast<uint16_t*>(row.data())[i] = code(x, y, c) * 257;
          if (bits == 32) reinterpret_cast<float*>(row.data())[i] = code(x, y, c) * 0.5f;
        }
      ASSERT_EQ(TIFFWriteScanline(t, row.data(), y, 0), 1);
    }
    TIFFClose(t);
    const LoadedImage li = read_image(path, w, h);
    EXPECT_EQ(li.bits, bits == 32 ? 0 : bits);
    ASSERT_EQ(li.image.channels, 3);
    double worst = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const double want = bits == 32 ? code(x, y, c) * 0.5 : code(x, y, c) / 255.0;
          worst = std::max(worst, std::abs(li.image.at(x, y, c) - want));
        }
    EXPECT_LT(worst, 1e-6) << path;
  }
}

// JPEG as libjpeg writes it, grey and RGB, within its quantisation; a truncated file is named in
// the message.
TEST(ImageIO, JpegFromLibjpegDecodes) {
  const std::string dir = test::tmp_dir("jpeg");
  const int w = 19, h = 7;
  for (int channels : {1, 3}) {
    const std::string path = dir + "/j" + std::to_string(channels) + ".jpg";
    jpeg_compress_struct ci;
    jpeg_error_mgr err;
    ci.err = jpeg_std_error(&err);
    jpeg_create_compress(&ci);
    FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    jpeg_stdio_dest(&ci, f);
    ci.image_width = w;
    ci.image_height = h;
    ci.input_components = channels;
    ci.in_color_space = channels == 3 ? JCS_RGB : JCS_GRAYSCALE;
    jpeg_set_defaults(&ci);
    jpeg_set_quality(&ci, 100, TRUE);
    jpeg_start_compress(&ci, TRUE);
    std::vector<unsigned char> row(static_cast<size_t>(w) * channels);
    while (ci.next_scanline < ci.image_height) {
      const int y = static_cast<int>(ci.next_scanline);
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < channels; ++c) row[x * channels + c] = 100 + x * 3 + c * 20 + y;
      JSAMPROW p = row.data();
      jpeg_write_scanlines(&ci, &p, 1);
    }
    jpeg_finish_compress(&ci);
    jpeg_destroy_compress(&ci);
    std::fclose(f);
    const LoadedImage li = read_image(path, w, h);
    EXPECT_EQ(li.bits, 8);
    ASSERT_EQ(li.image.channels, channels);
    double worst = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < channels; ++c)
          worst =
              std::max(worst, std::abs(li.image.at(x, y, c) * 255.0 - (100 + x * 3 + c * 20 + y)));
    EXPECT_LE(worst, 4) << path << ": codes off by more than JPEG's quality-100 rounding";
    // Row by row (what import merges from): the same codes as the whole image.
    auto rows = read_image_rows(path);
    ASSERT_TRUE(rows);
    ASSERT_EQ(rows->channels, channels);
    int differ = 0;
    for (int y = 0; y < h; ++y) {
      const uint16_t* row = rows->next();
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < channels; ++c)
          differ += static_cast<float>(row[x * channels + c] * (1.0 / 255)) != li.image.at(x, y, c);
    }
    EXPECT_EQ(differ, 0) << path;
  }
  // A JPEG cut short: the decoder's own message, the file named.
  const std::string cut = dir + "/cut.jpg";
  {
    std::ifstream in(dir + "/j3.jpg", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, 40);
  }
  try {
    read_image(cut);
    ADD_FAILURE() << "a truncated JPEG was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(cut), std::string::npos) << e.what();
  }
}

// PNG rows as codes (what import merges a bracket from): an Adam7-interlaced 16-bit RGBA file and
// a plain 8-bit grey-and-alpha one, written by libpng itself, read row by row give their codes
// exactly, alpha dropped, and read_image gives the same values scaled; a file cut short is an
// error naming it, not rows of zeros.
TEST(ImageIO, PngRowsAreTheFilesCodesInterlacedOrNot) {
  const std::string dir = test::tmp_dir("png_rows");
  const int w = 37, h = 23;
  auto code = [](int x, int y, int c, int bits) {
    return bits == 16 ? (x * 1733 + y * 2711 + c * 9973) % 65536 : (x * 7 + y * 13 + c * 50) % 256;
  };
  struct Case {
    int bits, type, interlace, channels;
  };
  for (const Case k : {Case{16, PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_ADAM7, 4},
                       Case{8, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_INTERLACE_NONE, 2}}) {
    const std::string path = dir + "/p" + std::to_string(k.bits) + ".png";
    FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_init_io(png, f);
    png_set_IHDR(png, info, w, h, k.bits, k.type, k.interlace, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    const size_t bytes = k.bits / 8;
    std::vector<unsigned char> img(static_cast<size_t>(w) * h * k.channels * bytes);
    std::vector<png_bytep> rows(h);
    for (int y = 0; y < h; ++y) {
      rows[y] = img.data() + static_cast<size_t>(y) * w * k.channels * bytes;
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < k.channels; ++c) {
          const int v = code(x, y, c, k.bits);
          unsigned char* p = rows[y] + (x * k.channels + c) * bytes;
          if (k.bits == 16)
            p[0] = static_cast<unsigned char>(v >> 8), p[1] = static_cast<unsigned char>(v & 255);
          else
            p[0] = static_cast<unsigned char>(v);
        }
    }
    png_write_image(png, rows.data());
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
    const int colour = k.channels >= 3 ? 3 : 1;
    auto r = read_image_rows(path);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->width, w);
    ASSERT_EQ(r->height, h);
    ASSERT_EQ(r->channels, colour);
    EXPECT_EQ(r->bits, k.bits);
    const LoadedImage li = read_image(path);
    ASSERT_EQ(li.image.channels, colour);
    int wrong = 0, scaled_wrong = 0;
    const double q = k.bits == 16 ? 65535 : 255;
    for (int y = 0; y < h; ++y) {
      const uint16_t* row = r->next();
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < colour; ++c) {
          wrong += row[x * colour + c] != code(x, y, c, k.bits);
          scaled_wrong += li.image.at(x, y, c) != static_cast<float>(code(x, y, c, k.bits) / q);
        }
    }
    EXPECT_EQ(wrong, 0) << path;
    EXPECT_EQ(scaled_wrong, 0) << path;
  }
  // Cut short: the rows stop with an error naming the file.
  const std::string cut = dir + "/cut.png";
  {
    std::ifstream in(dir + "/p8.png", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  try {
    auto r = read_image_rows(cut);
    for (int y = 0; y < h; ++y) r->next();
    ADD_FAILURE() << "a truncated PNG was read row by row";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(cut), std::string::npos) << e.what();
  }
  // A float file is not rows of codes: read it whole.
  write_exr(dir + "/f.exr", Image(4, 3, 3, 0.5f));
  EXPECT_EQ(read_image_rows(dir + "/f.exr"), nullptr);
}

TEST(ImageIO, RefusesNonFiniteValues) {
  const std::string dir = test::tmp_dir("img");
  Image a(2, 2, 3);
  a.px[3] = NAN;
  EXPECT_THROW(write_exr(dir + "/nan.exr", a), Error);
  EXPECT_FALSE(std::filesystem::exists(dir + "/nan.exr"));
  // Uncompressed (synth's default, our own encoder) too: a bad value in the last line leaves no
  // file nor a temporary behind, and the message names the file.
  Image b(300, 400, 3, 0.25f);
  for (const float bad : {NAN, INFINITY, -INFINITY}) {
    b.at(299, 399, 2) = bad;
    const std::string path = dir + "/late.exr";
    try {
      write_exr(path, b, ExrCompression::kNone);
      ADD_FAILURE() << "wrote " << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path + ": refusing to write a non-finite value"),
                std::string::npos)
          << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(path));
  }
  b.at(299, 399, 2) = 0.5f;
  write_exr(dir + "/late.exr", b,
            ExrCompression::kNone);  // the same image, finite: written and read back
  EXPECT_EQ(read_image(dir + "/late.exr").image.px, b.px);
  size_t files = 0;
  for (const auto& f : std::filesystem::directory_iterator(dir)) files += f.is_regular_file();
  EXPECT_EQ(files, 1u) << "a temporary was left";
}

TEST(MaterialIO, RoundTripAndPeriodicAngle) {
  const std::string dir = test::tmp_dir("mat");
  Material m;
  m.kd = {0.1, 0.2, 0.3};
  m.n = 123;
  m.fiber_angle_deg = 33;
  m.has_second_fiber = true;
  m.second_angle_deg = 120;
  m.second_weight = 0.4;
  nlohmann::json j;
  material_to_json(m, &j);
  j["fiber_angle_deg"] = 213.0;  // the same fiber: 213 - 180
  write_json_file(dir + "/m.json", j);
  const Material r = read_material(dir + "/m.json");
  EXPECT_DOUBLE_EQ(r.fiber_angle_deg, 33.0);
  EXPECT_DOUBLE_EQ(r.n, 123);
  EXPECT_TRUE(r.has_second_fiber);
  EXPECT_DOUBLE_EQ(r.second_weight, 0.4);
}

TEST(MaterialIO, OutOfBoundsNamesTheKey) {
  const std::string dir = test::tmp_dir("mat");
  std::ofstream(dir + "/m.json") << R"({"format":"aniso-material","version":1,"model":"line",
    "kd":[0.1,0.1,0.1],"ks":0.5,"n":0.2,"fiber_angle_deg":0})";
  try {
    read_material(dir + "/m.json");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("m.json: n: value 0.2 outside"), std::string::npos)
        << e.what();
  }
}

TEST(SampleTable, RoundTripAndErrors) {
  const std::string dir = test::tmp_dir("tab");
  std::ofstream(dir + "/t.csv")
      << "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,y\n30,0,40,180,0.5\n10,20,30,40,0.25\n";
  SampleTable t = read_table(dir + "/t.csv");
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.values, SampleTable::Values::kGrey);
  EXPECT_DOUBLE_EQ(t.rows[1].value[2], 0.25);
  write_table(dir + "/u.csv", t);
  EXPECT_EQ(read_table(dir + "/u.csv").rows[0].theta_o, 40);
  std::ofstream(dir + "/bad.csv") << "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n30,0,abc,0\n";
  try {
    read_table(dir + "/bad.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:2: theta_o_deg"), std::string::npos) << e.what();
  }
}

// A capture written by "another tool": 8-bit sRGB PNG, grey image, a black level; the reader
// decodes to linear and leaves clipped values out.
TEST(CaptureIO, DecodesSrgbPngAndSkipsSaturated) {
  const std::string dir = test::tmp_dir("cap");
  std::filesystem::create_directories(dir + "/g");
  Image grey(4, 1, 1);
  grey.px = {0.0f, 0.5f, 0.21404f, 1.0f};  // sRGB 0.5 -> linear 0.214, last one clipped
  write_png(dir + "/img.png", grey, 8);
  Image P(4, 1, 3), N(4, 1, 3), U(4, 1, 3);
  for (int x = 0; x < 4; ++x) {
    P.at(x, 0, 0) = float(x);
    N.at(x, 0, 2) = 1;
    U.at(x, 0, 0) = 1;
  }
  write_exr(dir + "/g/P.exr", P);
  write_exr(dir + "/g/N.exr", N);
  write_exr(dir + "/g/U.exr", U);
  std::ofstream(dir + "/capture.json") << R"({"format":"aniso-capture","version":1,
    "camera":{"width":4,"height":1,"fx":10,"fy":10,"cx":1.5,"cy":0},
    "color":{"encoding":"srgb"},
    "geometry":{"position":"g/P.exr","normal":"g/N.exr","tangent":"g/U.exr"},
    "views":[{"image":"img.png","world_from_camera":[[1,0,0,0],[0,1,0,0],[0,0,1,-3],[0,0,0,1]],
              "lights":[{"type":"directional","direction":[0,0,1],"irradiance":1}]}]})";
  const CaptureSet s = read_capture(dir);
  ASSERT_EQ(s.views.size(), 1u);
  EXPECT_EQ(s.views[0].lights[0].type, Light::Type::kDirectional);
  const ViewData d = load_view(s, 0);
  EXPECT_NEAR(d.rgb.at(1, 0, 1), 0.2140, 2e-3);  // sRGB 128/255 -> linear
  EXPECT_EQ(d.saturated, 1u);
  EXPECT_EQ(d.used, 3u);
}

// A band's load classifies the pixels of its rows alone; the rows it does not read are kOff, also
// in pixel states reused from another band's load once clear_pixel_states has cleared them.
TEST(CaptureIO, ABandsLoadLeavesTheRowsItDoesNotReadOff) {
  const std::string dir = test::tmp_dir("bandrows");
  std::filesystem::create_directories(dir + "/g");
  Image P(4, 4, 3), N(4, 4, 3), U(4, 4, 3), img(4, 4, 3, 0.5f);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      P.at(x, y, 0) = float(x), P.at(x, y, 1) = float(y);
      N.at(x, y, 2) = 1;
      U.at(x, y, 0) = 1;
    }
  for (int c = 0; c < 3; ++c) img.at(0, 0, c) = img.at(3, 2, c) = 2.f;  // saturated
  write_exr(dir + "/g/P.exr", P);
  write_exr(dir + "/g/N.exr", N);
  write_exr(dir + "/g/U.exr", U);
  write_exr(dir + "/img.exr", img);
  std::ofstream(dir + "/capture.json") << R"({"format":"aniso-capture","version":1,
    "camera":{"width":4,"height":4,"fx":10,"fy":10,"cx":1.5,"cy":1.5},
    "color":{"encoding":"linear","saturation":1.0},
    "geometry":{"position":"g/P.exr","normal":"g/N.exr","tangent":"g/U.exr"},
    "views":[{"image":"img.exr","world_from_camera":[[1,0,0,0],[0,1,0,0],[0,0,1,-3],[0,0,0,1]],
              "lights":[{"type":"directional","direction":[0,0,1],"irradiance":1}]}]})";
  const CaptureSet s = read_capture(dir);
  const std::vector<uint8_t> top{1, 1, 0, 0}, bottom{0, 0, 1, 1};
  const ViewRows top_rows = [&](const std::shared_ptr<const ViewGeometry>&) -> const auto& {
    return top;
  };
  const ViewRows bottom_rows = [&](const std::shared_ptr<const ViewGeometry>&) -> const auto& {
    return bottom;
  };
  auto row_states = [](const ViewData& d, int y) {
    return std::vector<uint8_t>(d.use.begin() + 4 * y, d.use.begin() + 4 * y + 4);
  };
  const std::vector<uint8_t> off(4, ViewData::kOff);
  ViewData d;
  load_view_into(s, 0, &d, nullptr, nullptr, &top_rows);
  EXPECT_EQ(d.use[0], ViewData::kSaturated);
  EXPECT_EQ(row_states(d, 1), std::vector<uint8_t>(4, ViewData::kUsable));
  EXPECT_EQ(row_states(d, 2), off);
  EXPECT_EQ(row_states(d, 3), off);
  ViewData kept = d;  // not cleared: what a reused allocation would hold without clearing
  clear_pixel_states(&d);
  EXPECT_EQ(d.use, std::vector<uint8_t>(16, ViewData::kOff));
  load_view_into(s, 0, &d, nullptr, nullptr, &bottom_rows);
  const ViewData fresh = load_view(s, 0, nullptr, nullptr, &bottom_rows);
  EXPECT_EQ(d.use, fresh.use);
  EXPECT_EQ(row_states(d, 0), off);
  EXPECT_EQ(row_states(d, 1), off);
  EXPECT_EQ(d.use[2 * 4 + 3], ViewData::kSaturated);
  EXPECT_EQ(d.saturated, 1u);
  EXPECT_EQ(d.used, 7u);
  // The check above can fail: without clear_pixel_states the first band's states stay.
  load_view_into(s, 0, &kept, nullptr, nullptr, &bottom_rows);
  EXPECT_EQ(kept.use[0], ViewData::kSaturated);
}

TEST(CaptureIO, WriteThenReadKeepsEverything) {
  const std::string dir = test::tmp_dir("cap");
  CaptureSet s;
  s.camera = {32, 16, 40, 41, 15.5, 7.5};
  s.ambient = {0.1, 0.2, 0.3};
  s.geometry.mesh = "m.obj";
  s.geometry.fiber_field = "circular";
  ViewSpec v;
  v.image = "images/000.exr";
  v.exposure = 0.5;
  v.camera = s.camera;
  Light l;
  l.type = Light::Type::kSpot;
  l.position = {1, 2, 3};
  l.direction = {0, 0, -1};
  l.cutoff_deg = 30;
  l.exponent = 4;
  v.lights.push_back(l);
  s.views.push_back(v);
  write_capture_json(s, dir + "/capture.json");
  const CaptureSet r = read_capture(dir + "/capture.json");
  EXPECT_EQ(r.camera.height, 16);
  EXPECT_DOUBLE_EQ(r.camera.fy, 41);
  EXPECT_DOUBLE_EQ(r.ambient[2], 0.3);
  EXPECT_EQ(r.views[0].geometry.fiber_field, "circular");
  EXPECT_EQ(r.views[0].lights[0].type, Light::Type::kSpot);
  EXPECT_DOUBLE_EQ(r.views[0].lights[0].cutoff_deg, 30);
  EXPECT_DOUBLE_EQ(r.views[0].exposure, 0.5);
}

TEST(Lights, AttenuationAndSpotCone) {  // docs/models.md §2
  Light p;
  p.position = {0, 0, 2};
  p.intensity = {8, 8, 8};
  p.attenuation = {1, 0, 1};
  Vec3 L;
  RGB E;
  double d;
  ASSERT_TRUE(light_at(p, {0, 0, 0}, &L, &E, &d));
  EXPECT_NEAR(E[0], 8.0 / 5.0, 1e-12);
  EXPECT_NEAR(L.z, 1.0, 1e-12);
  Light s = p;
  s.type = Light::Type::kSpot;
  s.direction = {0, 0, -1};
  s.cutoff_deg = 20;
  s.exponent = 2;
  EXPECT_TRUE(light_at(s, {0.1, 0, 0}, &L, &E, &d));
  EXPECT_FALSE(light_at(s, {2, 0, 0}, &L, &E, &d));  // outside the cone
}

// Inside a folder being written whole, files go straight to their names (subfolders made as
// needed) and nothing else lands beside them; the folder appears only when filled, and a fill
// that fails leaves the earlier output as it was. The mask PNG reads back as the mask.
TEST(Files, AFolderIsFilledInPlaceAndPublishedWhole) {
  namespace fs = std::filesystem;
  const std::string out = test::tmp_dir("staging") + "/set";
  const std::vector<uint8_t> on = {0, 1, 1, 0, 1, 0};
  write_folder_atomically(out, OutputKind::kBake, [&](const std::string& tmp) {
    write_text_file(tmp + "/a/b.txt", "first");
    write_mask_png(tmp + "/a/mask.png", on, 3, 2);
    EXPECT_FALSE(fs::exists(out));
    size_t entries = 0;
    for (const auto& e : fs::directory_iterator(tmp + "/a")) entries += !e.path().empty();
    EXPECT_EQ(entries, 2u);  // no temporary beside them
  });
  EXPECT_EQ(read_text_file(out + "/a/b.txt"), "first");
  const LoadedImage m = read_image(out + "/a/mask.png");
  ASSERT_EQ(m.image.px.size(), on.size());
  for (size_t i = 0; i < on.size(); ++i) EXPECT_EQ(m.image.px[i], on[i] ? 1.f : 0.f);
  EXPECT_THROW(write_folder_atomically(out, OutputKind::kBake,
                                       [&](const std::string& tmp) {
                                         write_text_file(tmp + "/a/b.txt", "second");
                                         throw Error("stopped part way");
                                       }),
               Error);
  EXPECT_EQ(read_text_file(out + "/a/b.txt"), "first");
}

}  // namespace
}  // namespace aniso

#include "io/files/json_util.h"
#include "models/topology.h"

namespace aniso {
namespace {

// The material's topology is one typed source, parsed once: contradictory blocks are
// refused, and each source survives a write and a read; s_at decides s the same way for all.
TEST(MaterialTypes, TopologySourcesRoundTripAndContradictionsAreRefused) {
  const std::string head = R"({"format": "aniso-material", "version": 1, "model": "fiber",
    "kd": 0.2, "ks": 0.5, "n": 20, "fiber_angle_deg": 10, "topology": )";
  auto parse = [&](const std::string& topo) {
    return material_from_json(jsonu::parse_file(head + topo + "}", "m.json"), "m.json");
  };
  for (const char* bad : {R"({"s": 0.3, "map": "t.png"})", R"({"s": 0.3, "mathematical": "torus"})",
                          R"({"s_map": "s.exr", "mathematical": "torus"})", R"({"amplitude": 0.3,
                          "mathematical": "torus"})",
                          R"({"mathematical": "tours"})"})
    EXPECT_THROW(parse(bad), Error) << bad;
  const Material u = parse(R"({"s": 0.3})");
  const Material t = parse(R"({"map": "t.png", "amplitude": 0.5, "mathematical": "torus"})");
  const Material x = parse(R"({"mathematical": "sphere"})");
  const Material s = parse(R"({"s_map": "s.exr"})");
  EXPECT_EQ(s_at(u, 0.9, 0.7), 0.3);
  EXPECT_EQ(s_at(x, 0.9, 0.7), 0.9);
  EXPECT_NEAR(s_at(t, 0.0, 1.0), topology_with_map(0.0, 0.5, 1.0), 1e-15);
  EXPECT_EQ(s_at(s, 0.9, 0.7), 0.7);
  for (const Material* m : {&u, &t, &x, &s}) {
    jsonu::json j;
    material_to_json(*m, &j);
    const Material back = material_from_json(j, "back.json");
    EXPECT_EQ(back.topology.index(), m->topology.index()) << j.dump();
    EXPECT_EQ(back.mathematical(), m->mathematical()) << j.dump();
  }
  EXPECT_EQ(t.topology_as<TopologyMapRef>()->amplitude, 0.5);
}

}  // namespace
}  // namespace aniso
