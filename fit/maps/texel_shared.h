// fit/ internal to the texel solvers (fit/maps/texel_line.cpp: the line model's;
// fit/maps/texel_fiber.cpp: the fiber model's): what a texel's solve shares with the others - the
// checks after it (the second look at another valley, psi's profile), the start's nodes, and the
// Ceres problem's pull and solve. Ceres and Eigen inside: included by those two files alone.
#pragma once
#include <ceres/iteration_callback.h>
#include <ceres/problem.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/angles.h"
#include "fit/maps/texel_sigmas.h"
#include "fit/solvers/line_solve.h"
#include "fit/solvers/start.h"
#include "fit/solvers/texel_lanes.h"
#include "models/params.h"

namespace aniso::fitting {

// The start grid's best node at least kOtherValleyDeg from the start's psi (the texel's second
// look: solve_texel_lm, solve_texel_ceres), with its cost and the best node's.
constexpr double kOtherValleyDeg = 45;
struct OtherValley {
  Core c;
  double cost = INFINITY, best_cost = INFINITY;
};

// Eight nodes psi[0 .. 8) at n = 2^log2n, k_d and k_s in closed form: in float from the lanes, or
// from the records in double.
void texel_nodes(const ObsSet& os, const std::vector<size_t>& idx, const TexelLanes* lanes,
                 const double* psi, int log2n, NodeFit* out);

// The texel's second look (the global fit's, fit/global/solve.cpp): where the start grid's best
// node in another valley (kOtherValleyDeg or more from the start) costs within kOtherValleyGate
// sigma^2 of the best node, the texel is solved from there too (solve_from). Where both converged,
// more than a degree apart, the lower minimum is taken, and where they are within kAsWellSigma2
// sigma^2 of each other in the sum of squares (fit/solvers/start.h) the data do not tell the two
// directions apart: the texel is not determined; so too where the second stopped before converging
// no more than that above the first (its sum of squares bounds its valley's from above). A first
// solve that stopped at its iteration limit where the second converged elsewhere is solved on from
// where it stopped (`resume`) before the two are compared: its sum of squares there bounds its
// valley's minimum only from above, so a second one lower is not yet the better; so too a second
// that stopped below the first. Two minima as good in one direction (within a degree), apart in the
// fiber model's topology value s alone, leave the direction known: the texel stays determined, each
// of its sigmas widened to the two minima's distance in that parameter. The cases that set these:
// docs/solver-rules.md "The other valley".
constexpr double kOtherValleyGate = kAsWellSigma2;

// Two solves settled in one valley: psi within a degree and the topology value s (the fiber
// model's; the line model's two solves keep the start's) within kSameS or two of b's sigmas.
// Not psi alone: fiber-flat-map's texel (1, 3) has two minima of the fiber model 0.55 degrees
// apart in psi, at s 0.35 and 0.63, the second's sum of squares 1.9 times the first's.
inline bool same_direction(const TexelResult& a, const TexelResult& b) {
  constexpr double kSameDeg = 1.0;
  return fiber_deg_distance(rad_to_deg(a.c.psi), rad_to_deg(b.c.psi)) < kSameDeg;
}
inline bool same_valley(const TexelResult& a, const TexelResult& b) {
  constexpr double kSameS = 0.02;
  return same_direction(a, b) && std::abs(a.s - b.s) <= std::max(kSameS, 2 * b.sigma[8]);
}
// Two minima as good in one direction, apart in the topology value s alone: each sigma widened to
// at least the two minima's distance in its parameter.
inline void widen_sigmas(const TexelResult& other, TexelResult* t) {
  Vec8 apart = pack_core(other.c) - pack_core(t->c);
  apart(7) = std::remainder(apart(7), M_PI);
  for (int k = 0; k < 8; ++k) t->sigma[k] = std::max(t->sigma[k], std::abs(apart(k)));
  t->sigma[8] = std::max(t->sigma[8], std::abs(other.s - t->s));
}
template <class SolveFrom, class Resume>
void texel_second_look(const OtherValley& other, size_t values, SolveFrom solve_from, Resume resume,
                       TexelResult* t) {
  if (!std::isfinite(other.cost)) return;
  const double dof = std::max(1.0, static_cast<double>(values) - 8);
  if (!(other.cost - other.best_cost <= kOtherValleyGate * other.best_cost / dof)) return;
  TexelResult second = solve_from(other.c);
  if (same_valley(second, *t)) return;
  if (!second.converged && second.rss < t->rss) {
    const TexelResult more = resume(second);
    if (more.rss <= second.rss) second = more;
  }
  if (!t->converged && second.converged) {
    const TexelResult more = resume(*t);
    if (more.converged) *t = more;
  }
  // A first solve that did not converge stays undetermined: a second that did is not taken for it.
  if (!t->converged) return;
  constexpr double kSigma2Floor = 1e-12;  // noise-free data
  const double s2 = std::max(std::min(t->rss, second.rss) / dof, kSigma2Floor);
  auto as_well_too = [&](const TexelResult& other) {
    if (same_direction(other, *t))
      widen_sigmas(other, t);
    else
      t->determined = false;
  };
  if (!second.converged) {
    if (second.rss - t->rss <= kAsWellSigma2 * s2) as_well_too(second);
    return;
  }
  const bool as_well = std::abs(t->rss - second.rss) <= kAsWellSigma2 * s2;
  if (second.rss < t->rss) std::swap(*t, second);  // `second` now the higher of the two
  if (as_well) as_well_too(second);
}

// Where the data do not know the texel's lobe (k_s in a channel, or n, with a sigma above its
// bounds' spread), the curvature of the sum of squares at the minimum does not bound psi: a lobe
// sharpened to a needle can be aimed at a pixel or two, its psi then "known" to a tenth of a degree
// while other directions, each with its own k_s and n, fit the data nearly as well. Satin-ball's
// orbit set at --maps 256x256 held three such texels, determined 77 to 83 degrees off the truth,
// sigma 0.06 to 0.36 degrees (Ceres, the fitter of record, at the same minima): one whose sum of
// squares with psi held anywhere from 105 to 135 degrees rose by under 7.2 sigma^2 (its minimum at
// 103), one within 2.8 sigma^2 from 45 to 90 (its minimum at 82). So such a texel's psi is checked
// by its profile: its sum of squares with psi held at every kProfileStepDeg from its minimum, first
// at the best node of a grid over n (k_d, k_s in closed form), then, where that node is within
// kProfileMarginSigma2 sigma^2 of deciding, solved with psi held from there (from the global fit's
// k_s and n instead, a lobe turned away from every pixel had no slope to leave by). Where psi held
// Delta away rises by no more than a sigma of kPsiUndeterminedDeg would give,
// (Delta / kPsiUndeterminedDeg)^2 sigma^2 (at most the second look's kAsWellSigma2), the direction
// is not known: the texel is not determined. A held solve lowers its node by less than the margin
// (docs/solver-rules.md "psi's profile").
constexpr double kProfileStepDeg = 15;
constexpr int kProfileHeld = 11;  // 180 / kProfileStepDeg - 1
constexpr double kProfileMarginSigma2 = 2 * kAsWellSigma2;
inline bool lobe_unknown(const TexelResult& t) {
  static const double ks = line_param("ks").spread(), n = line_param("n").spread();  // per texel
  return t.sigma[3] > ks || t.sigma[4] > ks || t.sigma[5] > ks ||
         std::exp(t.c.logn) * t.sigma[6] > n;
}
// `nodes(psi, log2n, out)`: the model's sum of squares at psi[0 .. kProfileHeld) with n = 2^log2n,
// k_d and k_s in closed form (the rest of the texel's numbers as solved); `solve_pinned(c)`: the
// texel solved from c with psi held. The line model's nodes: line_profile_nodes.
template <class Nodes, class SolvePinned>
void texel_psi_profile(size_t values, Nodes nodes, SolvePinned solve_pinned, TexelResult* t) {
  if (!t->determined || !lobe_unknown(*t)) return;
  double psi[kProfileHeld];
  for (int k = 0; k < kProfileHeld; ++k)
    psi[k] = wrap_half_turn(t->c.psi + deg_to_rad((k + 1) * kProfileStepDeg));
  NodeFit best[kProfileHeld];
  int best_log2n[kProfileHeld];
  for (int k = 0; k < kProfileHeld; ++k) best[k].cost = INFINITY, best_log2n[k] = 1;
  for (int log2n = 1; log2n <= 13; log2n += 2) {  // n = 2 .. 8192
    NodeFit f[kProfileHeld];
    nodes(psi, log2n, f);
    for (int k = 0; k < kProfileHeld; ++k)
      if (f[k].cost < best[k].cost) best[k] = f[k], best_log2n[k] = log2n;
  }
  const double dof = std::max(1.0, static_cast<double>(values) - 8);
  const double s2 = std::max(t->rss / dof, 1e-12);
  double apart[kProfileHeld], limit[kProfileHeld];  // degrees from the minimum, either way
  for (int k = 0; k < kProfileHeld; ++k) {
    apart[k] = std::min(k + 1, kProfileHeld - k) * kProfileStepDeg;
    limit[k] = std::min(kAsWellSigma2, std::pow(apart[k] / kPsiUndeterminedDeg, 2)) * s2;
  }
  // A node's sum of squares bounds the profile there from above: one within its limit decides.
  for (int k = 0; k < kProfileHeld; ++k)
    if (best[k].cost - t->rss <= limit[k]) {
      t->determined = false;
      return;
    }
  double rise[kProfileHeld];
  for (int k = 0; k < kProfileHeld; ++k) {
    rise[k] = best[k].cost - t->rss;
    if (rise[k] > limit[k] + kProfileMarginSigma2 * s2) continue;
    Core held = t->c;
    held.psi = psi[k];
    held.logn = best_log2n[k] * std::log(2.0);
    set_start_kd_ks(best[k].kd, best[k].ks, &held);
    rise[k] = std::min(rise[k], solve_pinned(held).rss - t->rss);
    if (rise[k] <= limit[k]) {
      t->determined = false;
      return;
    }
  }
  // Determined: psi's sigma is at least what the profile's rise within kProfileSigmaDeg of the
  // minimum says, Delta / sqrt(rise / sigma^2) (a rise of one sigma^2 a sigma away), where that is
  // more than the curvature at the minimum says. Satin-sphere-fiber's fiber texel (9, 33): sigma
  // 0.76 degrees from the curvature, psi 21.4 degrees off the truth; held 15 degrees away its sum
  // of squares rose as a sigma of 4.9 degrees would have it. Within 30 degrees the limits above
  // keep this under kPsiUndeterminedDeg.
  constexpr double kProfileSigmaDeg = 30;
  for (int k = 0; k < kProfileHeld; ++k)
    if (apart[k] <= kProfileSigmaDeg)
      t->sigma[7] = std::max(t->sigma[7], deg_to_rad(apart[k]) / std::sqrt(rise[k] / s2));
}
// The line model's nodes for texel_psi_profile: texel_nodes eight at a time.
inline auto line_profile_nodes(const ObsSet& os, const std::vector<size_t>& idx,
                               const TexelLanes* lanes) {
  return [&os, &idx, lanes](const double* psi, int log2n, NodeFit* out) {
    double at[16];
    for (int k = 0; k < 16; ++k) at[k] = psi[std::min(k, kProfileHeld - 1)];
    NodeFit f[16];
    texel_nodes(os, idx, lanes, at, log2n, f);
    texel_nodes(os, idx, lanes, at + 8, log2n, f + 8);
    std::copy(f, f + kProfileHeld, out);
  };
}

// A lobe that ends at the top of k_s's or n's bounds may have got there in one step that jumped
// the valley it was in: where k_s and n trade off along a ridge, a Gauss-Newton step far along it
// is clamped to the bounds' corner, which can cost less than the point it left and more than the
// ridge's own minimum, and stay there (its J^T J failing the rank test: not determined). Such a
// texel, where it is not determined there, is solved again from its start with the first step
// damped kCautiousLambda, not 1e-3, and the lower of the two kept (retrying the determined ones too
// loses more than it finds). The fiber model's solves are taken again so in both solvers wherever
// fiber_lobe_suspect (fit/maps/texel_fiber.cpp fiber_texel). The cases: docs/solver-rules.md
// "The cautious retry".
constexpr double kCautiousLambda = 1;
inline bool lobe_at_upper_bound(const Core& c) {
  static const double ks = line_param("ks").hi, n = line_param("n").hi;  // per texel
  return c.ks[0] >= ks || c.ks[1] >= ks || c.ks[2] >= ks || std::exp(c.logn) >= n * (1 - 1e-12);
}
// The fiber model's solves are taken again so where they end at the lobe's upper bounds or without
// a lobe (k_s at or under kNoLobeKs in every channel, or a lobe that lights no pixel: n held by
// texel_sigmas): undamped, either solver can end in a needle or without a lobe, the direction off;
// damped, both find the fibers' lobe (docs/solver-rules.md "A fiber texel without a lobe").
inline bool fiber_lobe_suspect(const TexelResult& t) {
  const Core& c = t.c;
  return lobe_at_upper_bound(c) || std::max({c.ks[0], c.ks[1], c.ks[2]}) <= kNoLobeKs ||
         t.sigma[6] >= kUnmovedSigma;
}

// The pull toward the neighbours (--smooth) as Ceres terms on the texel's core.
void add_prior(const TexelPrior& prior, ceres::Problem* pb, Core* c);
// Solves the texel's problem to double precision, then its sigmas from J^T J of the `data`
// residuals alone (not the pull) over `blocks` (one column each, in order; `hold`: texel_sigmas'
// without a lobe). With `ridge`, its rule (the parameters updated every
// iteration for it to read), a stop by which is converged. `trust_radius` (> 0): the first step's
// trust region, 1 / its damping (Ceres' own: 10^4).
void solve_and_sigmas(ceres::Problem* pb, const std::vector<ceres::ResidualBlockId>& data,
                      const std::vector<double*>& blocks, int max_iterations, TexelResult* t,
                      NoLobe hold, ceres::IterationCallback* ridge = nullptr,
                      double trust_radius = 0);

}  // namespace aniso::fitting
