// Baked lookup textures of the line-lighting model (MODELS.md §5; seed 000 §3, seed 002).
//
// D(a) and S(a, b; n) are tabulated over a = <L,T>, b = <V,T> in [-1, 1]^2 on an N x N grid whose
// first and last texel centres sit exactly on ±1, so grazing (T parallel to L) is sampled, not
// extrapolated. Two indexings, both reached from the paper's texture matrix s = (a + 1) / 2:
//  - cosine (the paper's): texel i at a_i = -1 + 2 i / (N - 1); the shader maps s to the texel
//    centre with u = (s (N - 1) + 0.5) / N, folded into the texture matrix;
//  - angle (default): texel i at acos(-a_i) = pi i / (N - 1); the shader adds one acos. Since
//    s_L s_V - a b = -cos(alpha + beta) with alpha = acos a, beta = acos b, the specular lobe is a
//    band of constant width in angle space, while in cosine space it pinches to nothing at the
//    corners (a, b) = ±(1, -1) where bilinear interpolation then fails: at n = 500 and N = 256 the
//    angle index cuts the worst error several-fold (measured: `aniso bake`, bench bake).
// Diffuse (grey D),
// specular (grey S, depends on n only) and the combined RGB k_d D + k_s S are separate tables so
// colours can change without re-baking. <N,L>^+ is applied per fragment, not baked.
#pragma once
#include <cstdint>
#include <string>

#include "core/image.h"
#include "models/material.h"

namespace aniso {

enum class BakeIndex { kCosine, kAngle };
const char* index_name(BakeIndex i);
BakeIndex parse_index(const std::string& name);  // "cosine" | "angle"; throws otherwise

struct BakeTables {
  int size = 0;
  BakeIndex index = BakeIndex::kAngle;
  Image diffuse;   // 1 channel: D
  Image specular;  // 1 channel: S
  Image combined;  // 3 channels: k_d D + k_s S
  // Error of bilinear lookup against direct evaluation of k_d D + k_s S, over `samples` random
  // (a, b) pairs (seeded) plus a dense line through the specular peak; max over channels.
  double max_abs_error = 0, rms_error = 0, peak_value = 0;
  size_t samples = 0;
  uint64_t seed = 0;
  double seconds = 0;
};

BakeTables bake_line(const Material& m, int size, BakeIndex index = BakeIndex::kAngle, uint64_t seed = 1);

// The cosine a at texel i, and the continuous texel coordinate in [0, N - 1] of a cosine a.
double texel_cosine(int i, int n, BakeIndex index);
double texel_coord(double a, int n, BakeIndex index);

// Bilinear lookup with the texel-centre convention above (a, b clamped to [-1, 1]).
double lookup_bilinear(const Image& table, double a, double b, int channel, BakeIndex index);

// Writes diffuse/specular/combined as float EXR, 8- and 16-bit PNG, and bake.json (the sidecar:
// indexing, decoding scales, texture matrix, measured error, the command that generated it).
void write_bake(const std::string& dir, const Material& m, const BakeTables& t, const std::string& command);

}  // namespace aniso
