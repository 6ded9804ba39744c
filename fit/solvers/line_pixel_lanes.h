// fit/ internal: the plain line model's fused pass four pixels at a time (AVX2 and FMA, chosen at
// run time; the scalar line_pixel_derivs everywhere else). The same function as
// fit/solvers/line_pixel.h, lane by lane: the transcendental parts (log and exp of the lobe, square
// roots) in 4-wide double precision with our own exp and log (within 2 ulp of libm's, tested), the
// robust weights for no loss and Huber's (Cauchy's stays scalar). Sums are per lane, added lane
// by lane at the end of a chunk: a fixed order, so a pass does not depend on the threads.
#pragma once
#include <cstddef>
#include <cstdint>

#include "fit/records/pixel_frames.h"
#include "fit/solvers/fused_lm.h"
#include "fit/solvers/line_pixel.h"

namespace aniso::fitting {

// Adds observations idx[0 .. count), each with exactly one light, to *sums (and, given `curv`,
// Huber's curvature).
void line_pass_simd(const ObsSet& os, const size_t* idx, size_t count, const LinePixelParams& p,
                    const RobustLoss& loss, bool jac, ChannelSums<8>* sums,
                    HuberCurvature<8>* curv = nullptr);

struct TexelLanes;
// The same over a texel's transposed rows (fit/solvers/texel_lanes.h), in double, without a robust
// loss: the texel's last passes after its float ones.
void line_pass_lanes(const TexelLanes& t, const LinePixelParams& p, bool jac, ChannelSums<8>* sums);

struct KdKsSums;
// Four nodes of the start's grid (fit/solvers/start.h, line_node_cost) at once, psi[i] in lane i,
// over observations idx[0 .. count): each node's k_d, k_s sums in out[i].
void line_nodes_simd(const ObsSet& os, const size_t* idx, size_t count, const double psi[4],
                     int log2n, KdKsSums out[4]);

// Four columns of the start's grid over (psi, n) at once (fit/solvers/start.cpp), psi[i] in lane i,
// over every observation of `os`: the sums of node (psi[i], n = 2^(k+1)) in out[i][k].
constexpr int kLineGridN = 12;
void line_grid_simd(const ObsSet& os, const double psi[4], KdKsSums out[4][kLineGridN]);

// The kernel's exp and log on four values at once, for the accuracy test (x > 0 for log; exp of
// a value below -708 is 0).
void simd_exp_log(const double in[4], double exp_out[4], double log_out[4]);

}  // namespace aniso::fitting
