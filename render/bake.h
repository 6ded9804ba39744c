// Baked lookup textures of the line-lighting model (MODELS.md §5; seed 000 §3, seed 002).
//
// D(a) and S(a, b; n) are tabulated over a = <L,T>, b = <V,T> in [-1, 1]^2 on an N x N grid whose
// texel centres sit exactly on a_i = -1 + 2 i / (N - 1), so a = ±1 (grazing, T parallel to L) is
// sampled, not extrapolated. A shader maps the paper's coordinate s = (a + 1) / 2 to the texel
// centre with u = (s (N - 1) + 0.5) / N, folded into the texture matrix. Diffuse (grey D),
// specular (grey S, depends on n only) and the combined RGB k_d D + k_s S are separate tables so
// colours can change without re-baking. <N,L>^+ is applied per fragment, not baked.
#pragma once
#include <cstdint>
#include <string>

#include "core/image.h"
#include "models/material.h"

namespace aniso {

struct BakeTables {
  int size = 0;
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

BakeTables bake_line(const Material& m, int size, uint64_t seed = 1);

// Bilinear lookup with the texel-centre convention above (a, b clamped to [-1, 1]).
double lookup_bilinear(const Image& table, double a, double b, int channel);

// Writes diffuse/specular/combined as float EXR, 8- and 16-bit PNG, and bake.json (the sidecar:
// indexing, decoding scales, texture matrix, measured error, the command that generated it).
void write_bake(const std::string& dir, const Material& m, const BakeTables& t, const std::string& command);

}  // namespace aniso
