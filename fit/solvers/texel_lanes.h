// fit/ internal: one texel of --maps eight observations at a time in float (AVX2 and FMA), or
// sixteen (AVX-512), chosen at run time (fit/solvers/texel_lanes_kernels.inc holds the kernels for
// both). A texel's start and its Levenberg-Marquardt read the same few hundred observations ten
// times or more, so they are transposed once (TexelLanes: float, structure of arrays, eight to a
// group) and every pass reads them straight from there; the lobe's exp and log in 8- or 16-wide
// float. Sums are per lane in float (a texel's lane sums a few dozen terms) and added in double at
// the end of the pass. The double 4-lane pass (fit/solvers/line_pixel_lanes.h) stays the global
// fit's and the reference of the tests.
#pragma once
#include <cmath>
#include <cstddef>
#include <vector>

#include "fit/solvers/fused_lm.h"
#include "fit/solvers/line_pixel.h"

namespace aniso::fitting {

struct KdKsSums;

// Per group of eight: u, w of V and L, n of L, the irradiance times n_L per channel, the value
// per channel, and 1 for an observation or 0 for padding: 12 x 8 floats.
struct TexelLanes {
  static constexpr int kRows = 12;
  // The groups f holds: an even number, the last all zero where `groups` is odd (the sixteen-lane
  // kernels read two groups at a time).
  static size_t stored_groups(size_t groups) { return (groups + 1) / 2 * 2; }
  size_t groups = 0, count = 0;
  std::vector<float> f;      // stored_groups(groups) * kRows * 8
  double yy[3] = {0, 0, 0};  // sum of the squared values, per channel
  bool grey_light = false;   // every light's irradiance the same in the three channels
  bool wide = false;         // its passes sixteen lanes at a time (AVX-512), else eight (AVX2)
};

// The texel's observations idx as lanes; false (*out is then not to be read) where the records'
// four-pixel passes are off (fit/records/pixel_frames.h line_lanes_on: no AVX2/FMA, or not asked)
// or an observation has other than one light.
// `wide` asks for the sixteen-lane kernels (AVX-512F, DQ and VL), taken where the CPU has them;
// else eight lanes (AVX2 and FMA). The choice travels with the lanes, so fits of different
// widths may run side by side in one process.
bool texel_lanes(const ObsSet& os, const std::vector<size_t>& idx, TexelLanes* out,
                 bool wide = false);

// Whether this CPU has the sixteen-lane kernels' AVX-512 (F, DQ and VL).
bool texel_avx512_available();
// The lanes a texel's passes take for a request: 16 where `wide` and the CPU allow, else 8; 0
// where texel_lanes refuses every texel (no AVX2 and FMA, or `simd` false).
int texel_float_lanes(bool simd, bool wide);

// The texel's pass at p (no robust loss, as every texel's fit): cost, and the J^T J and J^T r
// sums with `jac`.
void texel_pass_f32(const TexelLanes& t, const LinePixelParams& p, bool jac, ChannelSums<8>* s);

// The start grid's angles: m pi / 32, m in [0, 32) (texel_nodes_f32 has their cos and sin in a
// table).
inline double texel_grid_angle(int m) { return m * M_PI / 32; }

// Eight start nodes at once, psi[i] in lane i (n = 2^log2n, x^n by squaring): line_nodes_simd's
// sums (fit/solvers/line_pixel_lanes.h) from the lanes.
void texel_nodes_f32(const TexelLanes& t, const double psi[8], int log2n, KdKsSums out[8]);

}  // namespace aniso::fitting
