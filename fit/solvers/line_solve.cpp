#include "fit/solvers/line_solve.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "fit/solvers/line_pixel.h"
#include "fit/solvers/line_pixel_lanes.h"
#include "models/params.h"

namespace aniso::fitting {

void line_chunk(const ObsSet& os, const size_t* idx, size_t begin, size_t end,
                const LinePixelParams& p, const RobustLoss& loss, bool jac, ChannelSums<8>* s,
                HuberCurvature<8>* curv) {
  // Pixels with one light go four at a time where the CPU can (fit/solvers/line_pixel_lanes.h); the
  // rest, and Cauchy's loss, one at a time.
  const bool simd = line_lanes_on(os) && loss.kind != FitLoss::kCauchy;
  size_t ids[kFusedChunk];
  ObsRow<8> row;
  for (size_t b = begin; b < end; b += kFusedChunk) {
    size_t m = 0;
    for (size_t j = b; j < std::min(end, b + kFusedChunk); ++j) {
      const size_t i = idx ? idx[j] : j;
      if (simd && os.obs[i].num_lights == 1) {
        ids[m++] = i;
        continue;
      }
      PixelDerivs d;
      line_pixel_derivs(os.obs[i], os.lights.data(), p, &d);
      for (int k = 0; k < 3; ++k) {
        row.r[k] = d.r[k];
        row.dkd[k] = d.dkd[k];
        row.dks[k] = d.dks[k];
        row.shared[k][0] = d.dlogn[k];
        row.shared[k][1] = d.dpsi[k];
      }
      s->add(row, loss, jac, curv);
    }
    if (m) line_pass_simd(os, ids, m, p, loss, jac, s, curv);
  }
}

namespace {

// One pass at x: the robust cost and, with `jac`, J^T W J and J^T W r (W at x).
FusedSums<8> pass(const ObsSet& os, const std::vector<size_t>* subset, const Vec8& x,
                  const RobustLoss& loss, bool jac, tbb::task_arena* arena) {
  const double kd[3] = {x(0), x(1), x(2)}, ks[3] = {x(3), x(4), x(5)};
  const LinePixelParams p{kd, ks, std::exp(x(6)), std::cos(x(7)), std::sin(x(7))};
  const size_t n = subset ? subset->size() : os.obs.size();
  return fused_pass_chunks<8>(
      n, jac, arena, [&](size_t begin, size_t end, ChannelSums<8>* s, HuberCurvature<8>* curv) {
        line_chunk(os, subset ? subset->data() : nullptr, begin, end, p, loss, jac, s, curv);
      });
}

}  // namespace

Vec8 pack_core(const Core& c) {
  Vec8 x;
  x << c.kd[0], c.kd[1], c.kd[2], c.ks[0], c.ks[1], c.ks[2], c.logn, c.psi;
  return x;
}

void unpack_core(const Vec8& x, Core* c) {
  for (int k = 0; k < 3; ++k) c->kd[k] = x(k), c->ks[k] = x(3 + k);
  c->logn = x(6);
  c->psi = x(7);
}

void core_bounds(Vec8* lo, Vec8* hi) {
  for (int k = 0; k < 3; ++k) {
    (*lo)(k) = line_param("kd").lo, (*hi)(k) = line_param("kd").hi;
    (*lo)(3 + k) = line_param("ks").lo, (*hi)(3 + k) = line_param("ks").hi;
  }
  (*lo)(6) = std::log(line_param("n").lo), (*hi)(6) = std::log(line_param("n").hi);
  (*lo)(7) = -INFINITY, (*hi)(7) = INFINITY;
}

void line_lm_solve(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss_kind,
                   double scale, int max_iterations, int threads, Core* c, FusedSolve* out,
                   bool hold_psi) {
  tbb::task_arena arena(std::max(1, threads));
  const RobustLoss loss{loss_kind, scale};
  const double values = 3.0 * static_cast<double>(subset ? subset->size() : os.obs.size());
  Vec8 lo, hi;
  core_bounds(&lo, &hi);
  if (hold_psi) {
    c->psi = wrap_half_turn(c->psi);
    lo(7) = hi(7) = c->psi;
  }
  Vec8 x = pack_core(*c);
  FusedSums<8> cur;
  fused_lm<8>([&](const Vec8& at, bool jac) { return pass(os, subset, at, loss, jac, &arena); }, lo,
              hi, values, max_iterations, &x, &cur, out);
  unpack_core(x, c);
}

}  // namespace aniso::fitting
