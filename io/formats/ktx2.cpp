#include "io/formats/ktx2.h"

#include <cmath>
#include <cstring>

#include "core/error.h"
#include "io/files/files.h"

namespace aniso {

namespace {

constexpr uint8_t kIdentifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32,
                                     0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
constexpr size_t kHeaderBytes = 80, kLevelIndexBytes = 24;

// Khronos Data Format Specification 1.3: the basic descriptor block.
constexpr uint32_t kModelRgbsda = 1, kPrimariesBt709 = 1, kTransferLinear = 1;
constexpr uint32_t kQualifierFloat = 0x80, kQualifierSigned = 0x40;
constexpr uint32_t kChannelAlpha = 15;
constexpr uint32_t kFloatMinusOne = 0xBF800000u, kFloatOne = 0x3F800000u;

int type_size(KtxFormat f) { return f == KtxFormat::kRGBA16Float ? 2 : 4; }
int texel_bytes(KtxFormat f) { return type_size(f) * ktx_channels(f); }

void put32(std::vector<uint8_t>* b, uint32_t v) {
  for (int i = 0; i < 4; ++i) b->push_back(static_cast<uint8_t>(v >> (8 * i)));
}
void set32(std::vector<uint8_t>* b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) (*b)[at + i] = static_cast<uint8_t>(v >> (8 * i));
}
void set64(std::vector<uint8_t>* b, size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) (*b)[at + i] = static_cast<uint8_t>(v >> (8 * i));
}
uint32_t get32(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(b[at + i]) << (8 * i);
  return v;
}
uint64_t get64(const std::vector<uint8_t>& b, size_t at) {
  return get32(b, at) | (static_cast<uint64_t>(get32(b, at + 4)) << 32);
}
void pad_to(std::vector<uint8_t>* b, size_t align) {
  while (b->size() % align) b->push_back(0);
}

// The data format descriptor: total size, then one basic block with a sample per channel.
std::vector<uint8_t> descriptor(KtxFormat f) {
  const int channels = ktx_channels(f), bits = 8 * type_size(f);
  std::vector<uint8_t> d;
  const uint32_t block = 24 + 16 * channels;
  put32(&d, 4 + block);           // dfdTotalSize
  put32(&d, 0);                   // vendorId 0 (Khronos), descriptorType 0 (basic)
  put32(&d, 2u | (block << 16));  // versionNumber 2 (KDFS 1.3), descriptorBlockSize
  put32(&d, kModelRgbsda | (kPrimariesBt709 << 8) | (kTransferLinear << 16));  // flags 0: straight
  put32(&d, 0);  // texelBlockDimension 1x1x1x1 (stored minus one)
  put32(&d, static_cast<uint32_t>(texel_bytes(f)));  // bytesPlane0
  put32(&d, 0);                                      // bytesPlane4..7
  for (int c = 0; c < channels; ++c) {
    const uint32_t id = channels == 4 && c == 3 ? kChannelAlpha : static_cast<uint32_t>(c);
    const uint32_t type = id | kQualifierFloat | kQualifierSigned;
    put32(&d,
          static_cast<uint32_t>(c * bits) | (static_cast<uint32_t>(bits - 1) << 16) | (type << 24));
    put32(&d, 0);  // sample position
    put32(&d, kFloatMinusOne);
    put32(&d, kFloatOne);
  }
  return d;
}

// Key/value data, sorted by key (a std::map is), each entry padded to 4 bytes.
std::vector<uint8_t> key_values(const std::map<std::string, std::string>& kv) {
  std::vector<uint8_t> out;
  for (const auto& [k, v] : kv) {
    put32(&out, static_cast<uint32_t>(k.size() + 1 + v.size() + 1));
    out.insert(out.end(), k.begin(), k.end());
    out.push_back(0);
    out.insert(out.end(), v.begin(), v.end());
    out.push_back(0);
    pad_to(&out, 4);
  }
  return out;
}

void check_texture(const KtxTexture& t) {
  if (ktx_channels(t.format) == 0) throw Error("ktx2: unsupported format");
  if (t.width < 1 || t.height < 1 || t.layers < 0 || t.width > 16384 || t.height > 16384 ||
      t.layers > 2048)
    throw Error("ktx2: size " + std::to_string(t.width) + "x" + std::to_string(t.height) + "x" +
                std::to_string(t.layers) + " out of range");
  const size_t n =
      static_cast<size_t>(t.width) * t.height * std::max(t.layers, 1) * ktx_channels(t.format);
  if (t.texels.size() != n)
    throw Error("ktx2: " + std::to_string(t.texels.size()) + " values for " + std::to_string(n) +
                " texel channels");
  for (float v : t.texels) {
    if (!std::isfinite(v)) throw Error("ktx2: a texel value is not finite");
    if (t.format == KtxFormat::kRGBA16Float && std::abs(v) > 65504.f)
      throw Error("ktx2: value " + std::to_string(v) + " beyond half float's 65504");
  }
}

}  // namespace

int ktx_channels(KtxFormat f) {
  switch (f) {
    case KtxFormat::kR32Float:
      return 1;
    case KtxFormat::kRGBA16Float:
    case KtxFormat::kRGBA32Float:
      return 4;
  }
  return 0;
}

const char* ktx_format_name(KtxFormat f) {
  switch (f) {
    case KtxFormat::kR32Float:
      return "VK_FORMAT_R32_SFLOAT";
    case KtxFormat::kRGBA16Float:
      return "VK_FORMAT_R16G16B16A16_SFLOAT";
    case KtxFormat::kRGBA32Float:
      return "VK_FORMAT_R32G32B32A32_SFLOAT";
  }
  return "?";
}

uint16_t float_to_half(float f) {
  uint32_t x;
  std::memcpy(&x, &f, 4);
  const uint32_t sign = (x >> 16) & 0x8000u;
  x &= 0x7FFFFFFFu;
  if (x >= 0x47800000u) return static_cast<uint16_t>(sign | 0x7C00u);  // overflow (checked before)
  if (x < 0x38800000u) {  // a half subnormal or zero: round the shifted mantissa to nearest even
    if (x < 0x33000000u) return static_cast<uint16_t>(sign);
    // f = m24 2^(e - 150) with the implicit bit; a half subnormal is h 2^-24: h = m24 >> (126 - e).
    const uint32_t e = x >> 23, m = (x & 0x7FFFFFu) | 0x800000u;
    const uint32_t s = 126 - e;
    uint32_t h = m >> s;
    const uint32_t rest = m & ((1u << s) - 1), half = 1u << (s - 1);
    if (rest > half || (rest == half && (h & 1))) ++h;
    return static_cast<uint16_t>(sign | h);
  }
  uint32_t h = ((x - 0x38000000u) >> 13);
  const uint32_t rest = x & 0x1FFFu;
  if (rest > 0x1000u || (rest == 0x1000u && (h & 1))) ++h;
  return static_cast<uint16_t>(sign | h);
}

float half_to_float(uint16_t h) {
  const uint32_t sign = static_cast<uint32_t>(h & 0x8000u) << 16;
  const uint32_t e = (h >> 10) & 0x1F, m = h & 0x3FF;
  float v;
  if (e == 0)
    v = std::ldexp(static_cast<float>(m), -24);
  else if (e == 31)
    v = m ? NAN : INFINITY;
  else
    v = std::ldexp(static_cast<float>(m | 0x400), static_cast<int>(e) - 25);
  uint32_t x;
  std::memcpy(&x, &v, 4);
  x |= sign;
  std::memcpy(&v, &x, 4);
  return v;
}

std::vector<uint8_t> encode_ktx2(const KtxTexture& t) {
  check_texture(t);
  std::vector<uint8_t> b(kIdentifier, kIdentifier + 12);
  put32(&b, static_cast<uint32_t>(t.format));
  put32(&b, static_cast<uint32_t>(type_size(t.format)));
  put32(&b, static_cast<uint32_t>(t.width));
  put32(&b, static_cast<uint32_t>(t.height));
  put32(&b, 0);  // pixelDepth: not a 3D texture
  put32(&b, static_cast<uint32_t>(t.layers));
  put32(&b, 1);  // faceCount
  put32(&b, 1);  // levelCount: one level, no mipmaps (tables are sampled at their own size)
  put32(&b, 0);  // supercompressionScheme: none
  const size_t index_at = b.size();
  b.resize(kHeaderBytes + kLevelIndexBytes, 0);  // index and level index, filled below
  const std::vector<uint8_t> dfd = descriptor(t.format);
  const size_t dfd_at = b.size();
  b.insert(b.end(), dfd.begin(), dfd.end());
  std::map<std::string, std::string> kv = t.metadata;
  kv["KTXorientation"] = "rd";
  if (!kv.count("KTXwriter")) kv["KTXwriter"] = "aniso";
  const std::vector<uint8_t> kvd = key_values(kv);
  const size_t kvd_at = b.size();
  b.insert(b.end(), kvd.begin(), kvd.end());
  pad_to(&b, static_cast<size_t>(texel_bytes(t.format)) % 4 ? 4 : texel_bytes(t.format));
  const size_t level_at = b.size();
  for (float v : t.texels) {
    if (t.format == KtxFormat::kRGBA16Float) {
      const uint16_t h = float_to_half(v);
      b.push_back(static_cast<uint8_t>(h));
      b.push_back(static_cast<uint8_t>(h >> 8));
    } else {
      uint32_t x;
      std::memcpy(&x, &v, 4);
      put32(&b, x);
    }
  }
  const uint64_t level_bytes = b.size() - level_at;
  set32(&b, index_at, static_cast<uint32_t>(dfd_at));
  set32(&b, index_at + 4, static_cast<uint32_t>(dfd.size()));
  set32(&b, index_at + 8, static_cast<uint32_t>(kvd.empty() ? 0 : kvd_at));
  set32(&b, index_at + 12, static_cast<uint32_t>(kvd.size()));
  set64(&b, index_at + 16, 0);  // no supercompression global data
  set64(&b, index_at + 24, 0);
  set64(&b, kHeaderBytes, level_at);
  set64(&b, kHeaderBytes + 8, level_bytes);
  set64(&b, kHeaderBytes + 16, level_bytes);
  return b;
}

void write_ktx2(const std::string& path, const KtxTexture& t) {
  const std::vector<uint8_t> bytes = encode_ktx2(t);
  write_text_file(path, std::string(bytes.begin(), bytes.end()));
}

KtxTexture read_ktx2(const std::string& path) {
  const std::string s = read_text_file(path);
  const std::vector<uint8_t> b(s.begin(), s.end());
  auto bad = [&](const std::string& what) {
    return Error(path + ": not a KTX2 file aniso reads: " + what);
  };
  if (b.size() < kHeaderBytes + kLevelIndexBytes || std::memcmp(b.data(), kIdentifier, 12) != 0)
    throw bad("identifier");
  KtxTexture t;
  const uint32_t fmt = get32(b, 12);
  t.format = static_cast<KtxFormat>(fmt);
  if (ktx_channels(t.format) == 0) throw bad("vkFormat " + std::to_string(fmt));
  if (get32(b, 16) != static_cast<uint32_t>(type_size(t.format))) throw bad("typeSize");
  t.width = static_cast<int>(get32(b, 20));
  t.height = static_cast<int>(get32(b, 24));
  if (get32(b, 28) != 0) throw bad("pixelDepth (3D textures)");
  t.layers = static_cast<int>(get32(b, 32));
  if (get32(b, 36) != 1) throw bad("faceCount");
  if (get32(b, 40) != 1) throw bad("levelCount (one level)");
  if (get32(b, 44) != 0) throw bad("supercompressionScheme");
  if (t.width < 1 || t.height < 1 || t.width > 16384 || t.height > 16384 || t.layers > 2048)
    throw bad("size");
  const uint64_t at = get64(b, kHeaderBytes), len = get64(b, kHeaderBytes + 8);
  const size_t n =
      static_cast<size_t>(t.width) * t.height * std::max(t.layers, 1) * ktx_channels(t.format);
  if (len != n * type_size(t.format) || at > b.size() || len > b.size() - at)
    throw bad("level 0 size");
  t.texels.resize(n);
  for (size_t i = 0; i < n; ++i) {
    if (t.format == KtxFormat::kRGBA16Float) {
      t.texels[i] = half_to_float(static_cast<uint16_t>(b[at + 2 * i] | (b[at + 2 * i + 1] << 8)));
    } else {
      const uint32_t x = get32(b, at + 4 * i);
      std::memcpy(&t.texels[i], &x, 4);
    }
  }
  return t;
}

}  // namespace aniso
