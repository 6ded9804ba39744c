// KTX 2.0 (Khronos Texture Container, https://registry.khronos.org/KTX/specs/2.0/ktxspec.v2.html)
// for float lookup tables: one mip level, no supercompression, 2D or 2D-array, with the Basic
// Data Format Descriptor the spec requires (RGBSDA colour model, linear transfer, BT.709
// primaries, float samples). Debian has no libktx: this writer follows the spec and the tests
// read its files back with an independent reader (npm ktx-parse).
//
// Row order: the first row stored is texture coordinate t = 0 (KTXorientation "rd": x right,
// y down from the first row); an OpenGL upload of the same bytes puts it at t = 0 too.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace aniso {

enum class KtxFormat : uint32_t {
  kR32Float = 100,     // VK_FORMAT_R32_SFLOAT
  kRGBA16Float = 97,   // VK_FORMAT_R16G16B16A16_SFLOAT
  kRGBA32Float = 109,  // VK_FORMAT_R32G32B32A32_SFLOAT
};
int ktx_channels(KtxFormat f);
const char* ktx_format_name(KtxFormat f);

struct KtxTexture {
  KtxFormat format = KtxFormat::kR32Float;
  int width = 0, height = 0;
  int layers = 0;  // 0: a plain 2D texture; N >= 1: a 2D array of N layers
  // width * height * max(layers, 1) * channels floats: layer, then row (t), then column (s).
  std::vector<float> texels;
  std::map<std::string, std::string> metadata;  // written as key/value data (KTXwriter etc.)
};

// The container's bytes. Throws for sizes out of range, a texel count that does not match, or a
// value that is not finite or (half float) beyond 65504: nothing else reaches the file.
std::vector<uint8_t> encode_ktx2(const KtxTexture& t);
void write_ktx2(const std::string& path, const KtxTexture& t);  // atomic

// Reads what encode_ktx2 writes (the formats above, one level, no supercompression); anything
// else is an error naming the file and field.
KtxTexture read_ktx2(const std::string& path);

uint16_t float_to_half(float f);  // round to nearest even
float half_to_float(uint16_t h);

}  // namespace aniso
