#include "io/images/image_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string_view>
#include <vector>

#include "core/color.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/files/mapped_file.h"
#include "io/images/image_codecs.h"

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

Image read_exr(const std::string& path, int expect_w, int expect_h,
               const std::vector<uint8_t>* rows, bool zero_others);

Image read_exr_openexr(const std::string& path, int expect_w, int expect_h) {
  try {
    Imf::InputFile file(path.c_str());
    // The image is the display window; the file's pixels are the data window's.
    const Imath::Box2i dw = file.header().dataWindow(), disp = file.header().displayWindow();
    check_declared_size(path, static_cast<long long>(disp.max.x) - disp.min.x + 1,
                        static_cast<long long>(disp.max.y) - disp.min.y + 1, expect_w, expect_h);
    check_declared_size(path, static_cast<long long>(dw.max.x) - dw.min.x + 1,
                        static_cast<long long>(dw.max.y) - dw.min.y + 1, 0, 0);
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
    if (dw == disp) return img;
    // Placed in the display window, zeros around it.
    Image whole(disp.max.x - disp.min.x + 1, disp.max.y - disp.min.y + 1, img.channels);
    for (int y = std::max(dw.min.y, disp.min.y); y <= std::min(dw.max.y, disp.max.y); ++y)
      for (int x = std::max(dw.min.x, disp.min.x); x <= std::min(dw.max.x, disp.max.x); ++x)
        for (int c = 0; c < img.channels; ++c)
          whole.at(x - disp.min.x, y - disp.min.y, c) = img.at(x - dw.min.x, y - dw.min.y, c);
    return whole;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot read EXR: " + e.what());
  }
}

// Little-endian reads at a checked position of an EXR's bytes (false when past the end).
struct ByteReader {
  std::string_view b;
  size_t at = 0;
  template <class T>
  bool get(T* v) {
    if (at > b.size() || b.size() - at < sizeof(T)) return false;
    std::memcpy(v, b.data() + at, sizeof(T));
    at += sizeof(T);
    return true;
  }
  bool cstr(std::string* s) {
    const size_t end = b.find('\0', at);
    if (end == std::string::npos) return false;
    s->assign(b.substr(at, end - at));
    at = end + 1;
    return true;
  }
};

struct RawChannel {
  std::string name;
  int32_t type = 0, xs = 0, ys = 0;
};

// The header of a single-part scanline EXR: its channels, compression and data window; false on
// anything else (tiles, deep data, several parts, a malformed attribute).
bool parse_exr_header(ByteReader* r, std::vector<RawChannel>* ch, int* compression, int32_t box[4],
                      int32_t display[4]) {
  int32_t magic = 0, version = 0;
  if (!r->get(&magic) || magic != 20000630 || !r->get(&version)) return false;
  if ((version & 0xff) != 2 || (version & (0x200 | 0x800 | 0x1000))) return false;
  bool have_channels = false, have_box = false, have_display = false;
  *compression = -1;
  for (;;) {
    std::string name, type;
    int32_t size = 0;
    if (!r->cstr(&name)) return false;
    if (name.empty()) break;
    if (!r->cstr(&type) || !r->get(&size) || size < 0 || r->b.size() - r->at < size_t(size))
      return false;
    const size_t end = r->at + static_cast<size_t>(size);
    if (name == "channels" && type == "chlist") {
      for (;;) {
        RawChannel c;
        int32_t linear = 0;
        if (!r->cstr(&c.name) || r->at > end) return false;
        if (c.name.empty()) break;
        if (!r->get(&c.type) || !r->get(&linear) || !r->get(&c.xs) || !r->get(&c.ys)) return false;
        ch->push_back(c);
      }
      have_channels = r->at == end;
    } else if (name == "compression" && size == 1) {
      *compression = static_cast<unsigned char>(r->b[r->at]);
    } else if (name == "dataWindow" && type == "box2i" && size == 16) {
      for (int k = 0; k < 4; ++k) r->get(&box[k]);
      have_box = true;
    } else if (name == "displayWindow" && type == "box2i" && size == 16) {
      for (int k = 0; k < 4; ++k) r->get(&display[k]);
      have_display = true;
    }
    r->at = end;
  }
  if (have_box && !have_display) std::copy(box, box + 4, display);  // OpenEXR requires one
  return have_channels && have_box && *compression >= 0;
}

// The header of what decode_exr_uncompressed reads: no compression, every channel 32-bit float
// at full resolution.
bool uncompressed_float_header(ByteReader* r, std::vector<RawChannel>* ch, int32_t box[4],
                               int32_t display[4]) {
  int compression = -1;
  if (!parse_exr_header(r, ch, &compression, box, display) || compression != 0) return false;
  for (const RawChannel& c : *ch)
    if (c.type != 2 || c.xs != 1 || c.ys != 1) return false;
  return true;
}

}  // namespace

namespace {

bool decode_exr_bytes(std::string_view bytes, const std::string& path, int expect_w, int expect_h,
                      Image* out, const std::vector<uint8_t>* rows, bool zero_others) {
  ByteReader r{bytes};
  std::vector<RawChannel> ch;
  int32_t box[4] = {0, 0, 0, 0}, disp[4] = {0, 0, 0, 0};
  if (!uncompressed_float_header(&r, &ch, box, disp)) return false;
  // The image is the display window; the file holds the data window's rows (w x h values).
  const long long W = static_cast<long long>(disp[2]) - disp[0] + 1,
                  H = static_cast<long long>(disp[3]) - disp[1] + 1;
  check_declared_size(path, W, H, expect_w, expect_h);
  const long long w = static_cast<long long>(box[2]) - box[0] + 1,
                  h = static_cast<long long>(box[3]) - box[1] + 1;
  check_declared_size(path, w, h, 0, 0);
  const bool whole = std::equal(box, box + 4, disp);
  if (rows && rows->size() != static_cast<size_t>(H)) return false;
  auto wanted = [&](long long y) {  // a row of the data window the caller asks for
    return y >= disp[1] && y <= disp[3] && (!rows || (*rows)[y - disp[1]]);
  };
  // The channels read_exr_openexr picks (R[, G[, B]] or Y), each its place in the file's list.
  auto find = [&](const char* n) {
    for (size_t k = 0; k < ch.size(); ++k)
      if (ch[k].name == n) return static_cast<int>(k);
    return -1;
  };
  std::vector<int> pick;
  if (find("R") >= 0) {
    pick.push_back(find("R"));
    if (find("G") >= 0) {
      pick.push_back(find("G"));
      if (find("B") >= 0) pick.push_back(find("B"));
    } else if (find("B") >= 0) {
      return false;  // R and B without G: the OpenEXR path says so
    }
  } else if (find("Y") >= 0) {
    pick.push_back(find("Y"));
  } else {
    return false;
  }
  const size_t line = static_cast<size_t>(w) * ch.size() * sizeof(float);
  // out's allocation, if it has one, holds the image: every value is written below.
  Image img;
  img.px = std::move(out->px);
  img.width = static_cast<int>(W), img.height = static_cast<int>(H);
  img.channels = static_cast<int>(pick.size());
  const size_t nc = pick.size();
  img.px.resize(static_cast<size_t>(W) * H * nc);
  // A data window smaller than the display window: zeros around it (the allocation may be
  // reused); one that reaches past it: the part inside.
  if (!whole) {
    std::fill(img.px.begin(), img.px.end(), 0.f);
  } else if (rows && zero_others) {  // the rows not asked for
    for (long long y = 0; y < H; ++y)
      if (!(*rows)[y])
        std::fill_n(img.px.begin() + static_cast<size_t>(y) * W * nc, static_cast<size_t>(W) * nc,
                    0.f);
  }
  const long long xa = std::max<long long>(box[0], disp[0]),
                  xb = std::min<long long>(box[2], disp[2]);
  std::vector<uint8_t> seen(static_cast<size_t>(h), 0);
  for (long long k = 0; k < h; ++k) {
    uint64_t offset = 0;
    int32_t y = 0, size = 0;
    if (!r.get(&offset) || offset > bytes.size()) return false;
    // The offset table lists the blocks by increasing y, whatever order they are stored in: a
    // row not asked for is not looked at (its block may not have been read).
    if (rows && !wanted(box[1] + k)) continue;
    ByteReader block{bytes, static_cast<size_t>(offset)};
    if (!block.get(&y) || !block.get(&size) || static_cast<size_t>(size) != line ||
        bytes.size() - block.at < line || y < box[1] || y > box[3] || seen[y - box[1]]++ ||
        (rows && y != box[1] + k))
      return false;
    if (!wanted(y)) continue;
    const char* src = bytes.data() + block.at;
    float* dst = img.px.data() + static_cast<size_t>(y - disp[1]) * W * nc;
    for (size_t c = 0; c < nc; ++c)
      for (long long x = xa; x <= xb; ++x)
        std::memcpy(dst + (x - disp[0]) * nc + c,
                    src + (static_cast<size_t>(pick[c]) * w + (x - box[0])) * sizeof(float),
                    sizeof(float));
  }
  *out = std::move(img);
  return true;
}

}  // namespace

bool decode_exr_uncompressed(const std::string& bytes, const std::string& path, int expect_w,
                             int expect_h, Image* out, const std::vector<uint8_t>* rows,
                             bool zero_others) {
  return decode_exr_bytes(bytes, path, expect_w, expect_h, out, rows, zero_others);
}

namespace {

std::atomic<ExrReadBuffers::Impl*> g_read_buffers{nullptr};

// The file's first `n` bytes (fewer if it is shorter; empty if it cannot be read).
std::string read_prefix(const std::string& path, size_t n) {
  std::string out(n, '\0');
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return {};
  out.resize(std::fread(out.data(), 1, n, f));
  std::fclose(f);
  return out;
}

}  // namespace

struct ExrReadBuffers::Impl {
  tbb::enumerable_thread_specific<std::string> files;  // each thread's file bytes
  std::mutex mu;
  std::vector<std::vector<float>> spare;  // decoded images' allocations given back
};

namespace {

void keep_spare(ExrReadBuffers::Impl* impl, Image&& img) {
  if (!impl || img.px.empty()) return;
  std::lock_guard<std::mutex> lock(impl->mu);
  // Kept at most: a loader has 2 images per thread in flight, and a band's rows of views' own
  // geometry four buffers a view.
  constexpr size_t kMostSpare = 24;
  if (impl->spare.size() < kMostSpare) impl->spare.push_back(std::move(img.px));
}

}  // namespace

void ExrReadBuffers::give_back(Image&& img) { keep_spare(impl_.get(), std::move(img)); }

void give_back_to_read_buffers(Image&& img) { keep_spare(g_read_buffers.load(), std::move(img)); }

ExrReadBuffers::ExrReadBuffers() : impl_(std::make_unique<Impl>()) {
  Impl* none = nullptr;
  if (!g_read_buffers.compare_exchange_strong(none, impl_.get()))
    impl_.reset();  // another is alive: files are read as without one
}

ExrReadBuffers::~ExrReadBuffers() {
  if (impl_) g_read_buffers.store(nullptr);
}

namespace {

// Uncompressed float EXRs (what synth writes by default) at memory speed; everything else, and
// anything our reader does not follow, through OpenEXR. The header is looked at first, so a
// compressed file is read once (by OpenEXR), not twice.
// Of an uncompressed EXR whose header and offset table are in `head`: the header and table, and
// the blocks of the rows `rows` asks for (the offset table's entry k is row box[1] + k), read
// into *bytes at their places in the file (runs of adjacent blocks in one read); the rest of
// *bytes holds whatever it held. False where the table is not in `head` or the file cannot be
// read as it says.
bool read_exr_rows(const std::string& path, const std::string& head, size_t table_at,
                   const int32_t box[4], const int32_t disp[4], size_t line,
                   const std::vector<uint8_t>& rows, size_t file_size, std::string* bytes) {
  const long long h = static_cast<long long>(box[3]) - box[1] + 1;
  if (h < 1 || table_at + 8 * static_cast<size_t>(h) > head.size()) return false;
  std::vector<std::pair<uint64_t, uint64_t>> runs;  // [from, to) in the file
  for (long long k = 0; k < h; ++k) {
    const long long y = box[1] + k;
    if (y < disp[1] || y > disp[3] || !rows[y - disp[1]]) continue;
    uint64_t at = 0;
    std::memcpy(&at, head.data() + table_at + 8 * k, 8);
    const uint64_t end = at + 8 + line;
    if (at > file_size || end > file_size) return false;
    if (!runs.empty() && runs.back().second == at)
      runs.back().second = end;
    else
      runs.push_back({at, end});
  }
  bytes->resize(file_size);
  std::memcpy(bytes->data(), head.data(), std::min(head.size(), file_size));
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  bool ok = true;
  for (const auto& [from, to] : runs) {
    if (from < head.size() && to <= head.size()) continue;  // already there
    ok = ok && std::fseek(f, static_cast<long>(from), SEEK_SET) == 0 &&
         std::fread(bytes->data() + from, 1, to - from, f) == to - from;
  }
  std::fclose(f);
  return ok;
}

Image read_exr(const std::string& path, int expect_w, int expect_h,
               const std::vector<uint8_t>* rows, bool zero_others) {
  constexpr size_t kHeaderBytes = 64 << 10, kMaxDirect = size_t(1) << 30;
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  const std::string head = !ec && size < kMaxDirect ? read_prefix(path, kHeaderBytes) : "";
  ByteReader r{head};
  std::vector<RawChannel> ch;
  int32_t box[4], disp[4];
  if (!head.empty() && uncompressed_float_header(&r, &ch, box, disp)) {
    Image img;
    ExrReadBuffers::Impl* reuse = g_read_buffers.load();
    std::string fresh;
    std::string& bytes = reuse ? reuse->files.local() : fresh;
    const size_t line = static_cast<size_t>(box[2] - box[0] + 1) * ch.size() * sizeof(float);
    if (reuse) {  // a spare allocation large enough if there is one (no copy on growing), else any
      const size_t need =
          line / sizeof(float) * static_cast<size_t>(std::max(0, box[3] - box[1] + 1));
      std::lock_guard<std::mutex> lock(reuse->mu);
      auto& sp = reuse->spare;
      auto it =
          std::find_if(sp.begin(), sp.end(), [&](const auto& v) { return v.capacity() >= need; });
      if (it == sp.end() && !sp.empty()) it = sp.end() - 1;
      if (it != sp.end()) img.px = std::move(*it), sp.erase(it);
    }
    const long long H = static_cast<long long>(disp[3]) - disp[1] + 1;
    // The file mapped: the rows asked for are decoded straight from the page cache, where
    // reading them into a buffer first cost the kernel's copy (5 % of a 2048^2 fit's samples).
    // Where that fails, what the buffers below would try on the same bytes: the whole file, then
    // OpenEXR (not the same decode again from a buffer).
    if (MappedFile m(path, size); !m.empty()) {
      const std::vector<uint8_t>* asked =
          rows && static_cast<long long>(rows->size()) == H ? rows : nullptr;
      if (decode_exr_bytes(m.bytes(), path, expect_w, expect_h, &img, asked, zero_others) ||
          (asked && decode_exr_bytes(m.bytes(), path, expect_w, expect_h, &img, nullptr, true)))
        return img;
      return read_exr_openexr(path, expect_w, expect_h);
    }
    if (rows && static_cast<long long>(rows->size()) == H && box[2] >= box[0] &&
        read_exr_rows(path, head, r.at, box, disp, line, *rows, size, &bytes)) {
      if (decode_exr_uncompressed(bytes, path, expect_w, expect_h, &img, rows, zero_others))
        return img;
    }
    read_file_into(path, kMaxDirect, &bytes);
    if (decode_exr_uncompressed(bytes, path, expect_w, expect_h, &img)) return img;
  }
  return read_exr_openexr(path, expect_w, expect_h);
}

// Little-endian bytes (OpenEXR's byte order; the machines this builds for are little-endian too).
template <class T>
void put(std::string* out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out->append(b, sizeof(T));
}
void put_attribute(std::string* out, const char* name, const char* type, const std::string& value) {
  out->append(name, std::strlen(name) + 1);
  out->append(type, std::strlen(type) + 1);
  put<int32_t>(out, static_cast<int32_t>(value.size()));
  *out += value;
}

// One scanline's values channel by channel in the file's order (B, G, R: by name), from C
// interleaved channels; C a constant, so the strides are too.
template <int C>
__attribute__((target_clones("avx2", "default"))) void planar_row(const float* row, int w,
                                                                  float* planar) {
  for (int k = 0; k < C; ++k)
    for (int x = 0; x < w; ++x) planar[k * w + x] = row[x * C + (C - 1 - k)];
}

}  // namespace

void encode_exr_uncompressed(const Image& img, const ByteSink& sink, const std::string& software) {
  static_assert(sizeof(float) == 4, "EXR FLOAT is 32 bits");
  // Channels in the file's order, sorted by name: B, G, R (planar_row's order too).
  static const char* kNames[] = {"R", "G", "B"};
  std::string out("\x76\x2f\x31\x01", 4);
  put<int32_t>(&out, 2);  // version 2, single-part scanline, short names
  std::string chlist;
  for (int c = img.channels - 1; c >= 0; --c) {
    chlist.append(kNames[c], 2);  // name and its terminating zero
    put<int32_t>(&chlist, 2);     // FLOAT
    put<int32_t>(&chlist, 0);     // pLinear 0 and three reserved bytes
    put<int32_t>(&chlist, 1);     // x sampling
    put<int32_t>(&chlist, 1);     // y sampling
  }
  chlist.push_back('\0');
  std::string box;
  for (int32_t v : {0, 0, img.width - 1, img.height - 1}) put<int32_t>(&box, v);
  std::string one, zero2;
  put<float>(&one, 1.0f);
  put<float>(&zero2, 0.0f);
  put<float>(&zero2, 0.0f);
  put_attribute(&out, "channels", "chlist", chlist);
  put_attribute(&out, "compression", "compression", std::string(1, '\0'));  // NO_COMPRESSION
  put_attribute(&out, "dataWindow", "box2i", box);
  put_attribute(&out, "displayWindow", "box2i", box);
  put_attribute(&out, "lineOrder", "lineOrder", std::string(1, '\0'));  // INCREASING_Y
  put_attribute(&out, "pixelAspectRatio", "float", one);
  put_attribute(&out, "screenWindowCenter", "v2f", zero2);
  put_attribute(&out, "screenWindowWidth", "float", one);
  put_attribute(&out, "software", "string", software);
  out.push_back('\0');
  // The offset table (one scanline per block without compression), then the blocks: y, the
  // byte count, and the line's values channel by channel.
  const size_t line = static_cast<size_t>(img.width) * img.channels * sizeof(float);
  const size_t table = out.size(), first = table + 8 * static_cast<size_t>(img.height);
  for (int y = 0; y < img.height; ++y) put<uint64_t>(&out, first + y * (8 + line));
  sink(out.data(), out.size());
  // Blocks in batches of rows through one buffer of about 1 MiB per thread, kept for the thread's
  // next file (fresh pages from the kernel for each file cost more than the copy): a 256^2 RGB
  // file in one write with its header (write_file_pieces holds the header for it). A write of
  // 256 KiB costs the kernel about 12 % less per byte than one of 64 KiB (BENCHMARKS.md,
  // "Capture"); each write that grows a file costs a journaled ext4 an update of the inode too.
  constexpr size_t kBatchBytes = size_t(1) << 20;
  const size_t block = 2 + line / sizeof(float);  // in 4-byte words: y, the byte count, the line
  const int rows = static_cast<int>(std::max<size_t>(1, kBatchBytes / (4 * block)));
  thread_local std::vector<float> buf;
  buf.resize(static_cast<size_t>(std::min(rows, img.height)) * block);
  for (int y0 = 0; y0 < img.height; y0 += rows) {
    const int y1 = std::min(img.height, y0 + rows);
    float* b = buf.data();
    for (int y = y0; y < y1; ++y, b += block) {
      const int32_t head[2] = {y, static_cast<int32_t>(line)};
      std::memcpy(b, head, sizeof head);
      float* planar = b + 2;
      const float* row = img.px.data() + static_cast<size_t>(y) * img.width * img.channels;
      if (img.channels == 3)
        planar_row<3>(row, img.width, planar);
      else if (img.channels == 2)
        planar_row<2>(row, img.width, planar);
      else
        planar_row<1>(row, img.width, planar);
    }
    sink(reinterpret_cast<const char*>(buf.data()),
         sizeof(float) * static_cast<size_t>(b - buf.data()));
  }
}

ExrCompression exr_compression_named(const std::string& name) {
  if (name == "zip") return ExrCompression::kZip;
  if (name == "piz") return ExrCompression::kPiz;
  if (name == "none") return ExrCompression::kNone;
  throw Error("EXR compression must be zip, piz or none (got '" + name + "')");
}

namespace {

// Throws naming the file unless it exists and is a regular file (a folder, device or FIFO is not
// read as an image).
void check_image_file(const std::string& path) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(st)) throw Error(path + ": file not found");
  if (!std::filesystem::is_regular_file(st))
    throw Error(path + ": not a regular file (a folder, device or FIFO is not read)");
}

}  // namespace

LoadedImage read_image(const std::string& path, int expect_w, int expect_h,
                       const std::vector<uint8_t>* rows, bool zero_others) {
  check_image_file(path);
  LoadedImage out;
  if (lower_ext(path) == ".exr") {
    out.image = read_exr(path, expect_w, expect_h, rows, zero_others);
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

std::unique_ptr<CodeRows> read_image_rows(const std::string& path) {
  check_image_file(path);
  if (lower_ext(path) == ".exr") return nullptr;
  const SizeCheck check = [&](long long w, long long h) { check_declared_size(path, w, h, 0, 0); };
  switch (sniff_image(path)) {
    case ImageKind::kPng:
      return png_rows(path, check);
    case ImageKind::kJpeg:
      return jpeg_rows(path, check);
    default:
      return nullptr;
  }
}

void image_dimensions(const std::string& path, int* w, int* h) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(path + ": file not found (or not a regular file)");
  if (lower_ext(path) == ".exr") {
    try {
      Imf::InputFile file(path.c_str());
      const Imath::Box2i dw = file.header().dataWindow();
      *w = dw.max.x - dw.min.x + 1, *h = dw.max.y - dw.min.y + 1;
      return;
    } catch (const std::exception& e) {
      throw Error(path + ": cannot read EXR header: " + e.what());
    }
  }
  struct Probed {};  // thrown by the size check: the decoder stops before any pixel
  const SizeCheck check = [&](long long pw, long long ph) {
    check_declared_size(path, pw, ph, 0, 0);
    *w = static_cast<int>(pw), *h = static_cast<int>(ph);
    throw Probed{};
  };
  try {
    switch (sniff_image(path)) {
      case ImageKind::kPng:
        decode_png(path, check);
        break;
      case ImageKind::kJpeg:
        decode_jpeg(path, check);
        break;
      case ImageKind::kTiff:
        decode_tiff(path, check);
        break;
      case ImageKind::kOther:
        throw Error(path + ": cannot decode image (not PNG/TIFF/JPEG/EXR?)");
    }
  } catch (const Probed&) {
    return;
  }
  throw Error(path + ": no size in its header");
}

void write_exr(const std::string& path, const Image& img, ExrCompression c) {
  if (img.channels < 1 || img.channels > 3) throw Error(path + ": EXR writer takes 1-3 channels");
  if (!all_finite(img.px)) throw Error(path + ": refusing to write a non-finite value");
  if (c == ExrCompression::kNone) {
    // At memory speed: OpenEXR's scanline writer takes about ten times as long as writing the
    // bytes ourselves; read back by OpenEXR in the tests.
    const std::string software = output_stamp(path);
    write_file_pieces(path,
                      [&](const ByteSink& sink) { encode_exr_uncompressed(img, sink, software); });
    return;
  }
  write_atomically(path, [&](const std::string& tmp) {
    try {
      static const char* kNames[] = {"R", "G", "B"};
      Imf::Header header(img.width, img.height);
      // zlib level 1: within a few % of the default's size on float buffers, several times faster.
      constexpr int kZipLevel = 1;
      header.zipCompressionLevel() = kZipLevel;
      header.compression() =
          c == ExrCompression::kPiz ? Imf::PIZ_COMPRESSION : Imf::ZIP_COMPRESSION;
      header.insert("software", Imf::StringAttribute(output_stamp(path)));
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

void write_jpeg(const std::string& path, const Image& srgb, int quality) {
  write_text_file(path, encode_jpeg(path, srgb, quality));
}

void write_mask_png(const std::string& path, const std::vector<uint8_t>& on, int w, int h) {
  write_text_file(path, encode_mask_png(path, on, w, h));
}

void write_rgb8_png(const std::string& path, const std::vector<uint8_t>& rgb, int w, int h) {
  if (rgb.size() != static_cast<size_t>(w) * h * 3)
    throw Error(path + ": " + std::to_string(rgb.size()) + " bytes for " + std::to_string(w) + "x" +
                std::to_string(h) + " RGB pixels");
  write_text_file(path, encode_rgb8_png(path, rgb.data(), w, h));
}

Image encode_srgb(const Image& linear, double exposure) {
  Image out = linear;
  for (float& v : out.px) v = static_cast<float>(srgb_encode(v * exposure));
  return out;
}

}  // namespace aniso
