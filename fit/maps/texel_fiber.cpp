// The fiber model's texels of --maps (fit/maps/texel_solve.h): the start (psi from the line model's
// texel, then s over a grid, the fiber model's own nodes over psi kept for the second look), the
// fused solve or Ceres from it, and the second look from the other valley.
#include <ceres/normal_prior.h>

#include <Eigen/Dense>
#include <cmath>

#include "core/angles.h"
#include "fit/maps/texel_shared.h"
#include "fit/maps/texel_sigmas.h"
#include "fit/maps/texel_solve.h"
#include "fit/solvers/fiber_solve.h"
#include "fit/solvers/start.h"

namespace aniso::fitting {

namespace {

// The topology value the fiber model takes at observation i for the texel's value t (s, or a
// topology map's amplitude; s_math under a mathematical topology).
double pixel_topology(const ObsSet& os, size_t i, double t) {
  if (os.topology == TopologyMode::kAmplitude) return topology_with_map(os.smath(i), t, os.mapv(i));
  if (os.topology == TopologyMode::kMathematical) return os.smath(i);
  return t;
}

// The fiber model's own sum of squares over the texel at psi, exponent n and topology value s
// (amplitude or s by the set's topology; s_math per pixel under a mathematical one), k_d and k_s
// in closed form.
double fiber_node(const ObsSet& os, const std::vector<size_t>& idx, const FiberAccuracy& acc,
                  double psi, double n, double s, double kd[3], double ks[3]) {
  const double c = std::cos(psi), sn = std::sin(psi);
  return solve_kd_ks(
      os, idx,
      [&](size_t i, const Observation& ob, double* dcol, double* scol) {
        fiber_columns(os, ob, c, sn, n, pixel_topology(os, i, s), acc, dcol, scol);
      },
      kd, ks);
}

// The fiber model's nodes over psi (every 22.5 degrees, and the global psi) with k_d, k_s in closed
// form, and the start's own cost.
struct FiberNodes {
  static constexpr int kCount = 9;
  Core c[kCount];
  double cost[kCount];
  double start_cost = INFINITY;
};

// The second look's other valley of a fiber texel solved to psi: the best node kFiberOtherValleyDeg
// or more from where the solve ended, not from where it started (from the line model's psi the
// fiber solve can move 20-40 degrees, past the node of the valley it should have reached), and one
// node step, not the line model's kOtherValleyDeg: with 45 degrees from the start, 13 of the
// 64^2 set's 1 115 determined texels stayed more than 45 degrees off; from the end, 1 of 1 118
// (and 18 from 20 to 45 degrees); one node step from the end, none of 1 114 (1 from 20 to 45).
constexpr double kFiberOtherValleyDeg = 22.5;
OtherValley fiber_other_valley(const FiberNodes& nodes, double psi) {
  OtherValley o;
  o.best_cost = nodes.start_cost;
  for (int k = 0; k < FiberNodes::kCount; ++k)
    if (std::abs(std::remainder(nodes.c[k].psi - psi, M_PI)) >= deg_to_rad(kFiberOtherValleyDeg) &&
        nodes.cost[k] < o.cost)
      o.cost = nodes.cost[k], o.c = nodes.c[k];
  return o;
}

// The start's nodes over the topology value: s in [0, 1], or a topology map's amplitude A in
// [-2, 2] (models/params.h); topology_node_step apart.
constexpr int kTopologyNodes = 5;
const double* topology_nodes(TopologyMode m) {
  static constexpr double kS[kTopologyNodes] = {0.1, 0.3, 0.5, 0.7, 0.9},
                          kA[kTopologyNodes] = {-1.6, -0.8, 0.0, 0.8, 1.6};
  return m == TopologyMode::kAmplitude ? kA : kS;
}
double topology_node_step(TopologyMode m) { return topology_nodes(m)[1] - topology_nodes(m)[0]; }

// The second look over s, for the one over psi (fiber_other_valley): the best of the topology
// nodes at the solved psi and n (k_d, k_s in closed form) at least three quarters of a node step
// from the solved s, beside that node's cost at the solved s. The start picks s at the line
// model's psi, which on fiber-flat-map lies 5 to 15 degrees from the fiber model's (80 off in one
// texel): texel (1, 3) started at psi 17.8 took s 0.5 there and ended at s 0.63, n 35, its sum
// of squares 1.9 times that of the minimum at s 0.35 (n 42), 0.55 degrees away in psi, that
// a start at psi 21.9 reached; the one over psi, looking 22.5 degrees away, does not see it.
OtherValley topology_other_valley(const ObsSet& os, const std::vector<size_t>& idx,
                                  const FiberAccuracy& acc, const TexelResult& t, double* s) {
  OtherValley o;
  double kd[3], ks[3];
  const double n = std::exp(t.c.logn);
  o.best_cost = fiber_node(os, idx, acc, t.c.psi, n, t.s, kd, ks);
  const double* at = topology_nodes(os.topology);
  const double near = 0.75 * topology_node_step(os.topology);
  for (int k = 0; k < kTopologyNodes; ++k) {
    if (std::abs(at[k] - t.s) < near) continue;
    const double cost = fiber_node(os, idx, acc, t.c.psi, n, at[k], kd, ks);
    if (cost < o.cost) o.cost = cost, o.c = t.c, set_start_kd_ks(kd, ks, &o.c), *s = at[k];
  }
  return o;
}

// The fiber model's texel start: psi from the line model's texel grid (where the fibers lie flat
// the direction looks the same to both; the fiber model's own nodes, kept in `nodes`, check it),
// n from `from`, then s over a grid (s varies over the sample: started from the
// global s alone, texels far from it stopped in other minima, differently for the fused solver
// and Ceres) with k_d, k_s in closed form at every node; with a pull, `from` as it is.
TexelResult fiber_texel_start(const ObsSet& os, const std::vector<size_t>& idx,
                              const TexelResult& from, const TexelMapOptions& o,
                              const TexelPrior* prior, FiberNodes* nodes) {
  TexelResult t;
  t.c = from.c;
  t.s = from.s;
  if (prior) return t;
  // psi of the line model's own texel solve (its grid, then its LM: a few cheap passes), not of
  // a grid node: fiber-flat-map has texels with two minima of the fiber model 0.66 sigma apart,
  // and from a node 7.5 degrees off the fused solver and Ceres went to different ones.
  t.c.psi = solve_texel_lm(os, idx, from.c, nullptr, kTexelIterations, o.wide_lanes).c.psi;
  FiberAccuracy acc;
  acc.order = std::min(4, o.fiber_order);  // plenty to rank nodes, as the global start
  const double n = std::exp(t.c.logn);
  const bool math = os.topology == TopologyMode::kMathematical;
  auto node = [&](double psi, double s, double kd[3], double ks[3]) {
    return fiber_node(os, idx, acc, psi, n, s, kd, ks);
  };
  // The line model's psi is the fiber model's where the fibers lie flat; where they climb (a
  // mathematical topology, a sphere's fibers toward its poles) the lobe it sees is turned from
  // theirs, and a fiber solve from it can end in the wrong valley with a small sigma. So the fiber
  // model's own nodes every 22.5 degrees (and the global psi) are kept for the second look
  // (fiber_other_valley; docs/solver-rules.md "The fiber model's own nodes in ψ").
  if (nodes) {
    double kd[3], ks[3];
    nodes->start_cost = node(t.c.psi, t.s, kd, ks);
    for (int k = 0; k < FiberNodes::kCount; ++k) {
      Core& c = nodes->c[k];
      c = t.c;
      c.psi = k < 8 ? k * M_PI / 8 : from.c.psi;
      nodes->cost[k] = node(c.psi, t.s, kd, ks);
      set_start_kd_ks(kd, ks, &c);
    }
  }
  if (math) return t;  // s is not fitted
  double best = INFINITY;
  const double* at = topology_nodes(os.topology);
  for (const double s : {from.s, at[0], at[1], at[2], at[3], at[4]}) {
    double kd[3], ks[3];
    const double cost = node(t.c.psi, s, kd, ks);
    if (cost < best) best = cost, t.s = s, set_start_kd_ks(kd, ks, &t.c);
  }
  return t;
}

// A fiber texel: its start, `solve_from(start, prior, pin_psi, cautious)` (the fused solver's or
// Ceres'; `cautious`: its first step damped kCautiousLambda), and without a pull the second looks
// from the fiber model's other valley in psi and then in s (topology_other_valley), and psi's
// profile where the data do not know the lobe (texel_psi_profile, the fiber model's own nodes at
// the texel's s and quadrature order).
// A solve can end determined at the bounds' corner (k_s 100, n 10^4) with the direction off and a
// small sigma. Every solve without a pull that ends with its lobe at the top of its bounds or
// without one (fiber_lobe_suspect) is taken again cautiously from the same start, the lower kept,
// determined there or not (without a lobe the diffuse term determines the texel). One that stays
// suspect is solved a third time, from the global fit's lobe (k_s, n) at the psi it reached,
// damped, the lowest kept: a needle lighting no pixel can cost more than the lobe yet hold both
// solvers. The cases: docs/solver-rules.md "A fiber texel without a lobe".
template <class SolveFrom>
TexelResult fiber_texel(const ObsSet& os, const std::vector<size_t>& idx, const TexelResult& from,
                        const TexelMapOptions& o, const TexelPrior* prior,
                        SolveFrom solve_from_once) {
  auto solve_from = [&](const TexelResult& begin, const TexelPrior* p, bool pin_psi) {
    const TexelResult t = solve_from_once(begin, p, pin_psi, false);
    if (p || !fiber_lobe_suspect(t)) return t;
    const TexelResult again = solve_from_once(begin, nullptr, pin_psi, true);
    const TexelResult& best = again.rss < t.rss ? again : t;
    if (!fiber_lobe_suspect(best)) return best;
    TexelResult lobe = begin;  // the global fit's lobe at the psi reached
    std::copy(from.c.ks, from.c.ks + 3, lobe.c.ks);
    lobe.c.logn = from.c.logn;
    lobe.c.psi = best.c.psi;
    const TexelResult third = solve_from_once(lobe, nullptr, pin_psi, true);
    return third.rss < best.rss ? third : best;
  };
  FiberNodes nodes;
  const TexelResult start = fiber_texel_start(os, idx, from, o, prior, prior ? nullptr : &nodes);
  TexelResult t = solve_from(start, prior, false);
  if (prior) return t;
  texel_second_look(
      fiber_other_valley(nodes, t.c.psi), 3 * idx.size(),
      [&](const Core& c) {
        TexelResult s = start;
        s.c = c;
        return solve_from(s, nullptr, false);
      },
      [&](const TexelResult& r) { return solve_from(r, nullptr, false); }, &t);
  if (os.topology != TopologyMode::kMathematical) {
    FiberAccuracy nodes_acc;
    nodes_acc.order = std::min(4, o.fiber_order);  // as the start's nodes
    double other_s = t.s;
    texel_second_look(
        topology_other_valley(os, idx, nodes_acc, t, &other_s), 3 * idx.size(),
        [&](const Core& c) {
          TexelResult s = start;
          s.c = c, s.s = other_s;
          return solve_from(s, nullptr, false);
        },
        [&](const TexelResult& r) { return solve_from(r, nullptr, false); }, &t);
  }
  FiberAccuracy acc;
  acc.order = o.fiber_order;
  const double s = t.s;
  texel_psi_profile(
      3 * idx.size(),
      [&](const double* psi, int log2n, NodeFit* out) {
        for (int k = 0; k < kProfileHeld; ++k)
          out[k].cost =
              fiber_node(os, idx, acc, psi[k], std::ldexp(1.0, log2n), s, out[k].kd, out[k].ks);
      },
      [&](const Core& c) {
        TexelResult held = t;
        held.c = c;
        return solve_from(held, nullptr, true);
      },
      &t);
  return t;
}

}  // namespace

namespace {

// The same for the fiber model from `start` as it is: the autodiff residual of the global fit's
// Ceres path (fiber_pixel_cost), s bounded as there (fixed under a mathematical topology), the
// pull on s as one more NormalPrior.
TexelResult fiber_ceres_from(const ObsSet& os, const std::vector<size_t>& idx,
                             const TexelResult& start, const TexelMapOptions& o,
                             const TexelPrior* prior, bool pin_psi, bool cautious) {
  TexelResult t = start;
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem pb(po);
  Core& c = t.c;
  FiberAccuracy acc;
  acc.order = o.fiber_order;
  std::vector<ceres::ResidualBlockId> data;
  for (size_t i : idx)
    data.push_back(pb.AddResidualBlock(fiber_pixel_cost(os, i, os.topology, acc), nullptr, c.kd,
                                       c.ks, &c.logn, &c.psi, &t.s));
  const bool fit_s = os.topology != TopologyMode::kMathematical;
  if (prior) add_prior(*prior, &pb, &c);
  if (prior && fit_s && prior->ws > 0)
    pb.AddResidualBlock(
        new ceres::NormalPrior(Eigen::MatrixXd::Constant(1, 1, std::sqrt(prior->ws)),
                               Eigen::VectorXd::Constant(1, prior->bs)),
        nullptr, &t.s);
  set_core_bounds(&pb, &c);
  if (fit_s)
    set_param_bounds(&pb, &t.s, 0, texel_topology_key(os.topology));
  else
    pb.SetParameterBlockConstant(&t.s);
  if (pin_psi) pb.SetParameterBlockConstant(&c.psi);
  // (not a push_back of s: GCC 12 misreads that as past the list's end, -Warray-bounds, once
  // the sanitizer build's flags change what it inlines)
  std::vector<double*> blocks = {c.kd, c.ks, &c.logn, &c.psi, &t.s};
  if (!fit_s) blocks.pop_back();
  solve_and_sigmas(&pb, data, blocks, o.max_iterations, &t, NoLobe::kHoldLobe, nullptr,
                   cautious ? 1 / kCautiousLambda : 0);
  return t;
}

}  // namespace

TexelResult solve_texel_fiber_ceres(const ObsSet& os, const std::vector<size_t>& idx,
                                    const TexelResult& from, const TexelMapOptions& o,
                                    const TexelPrior* prior) {
  return fiber_texel(os, idx, from, o, prior,
                     [&](const TexelResult& s, const TexelPrior* p, bool pin_psi, bool cautious) {
                       return fiber_ceres_from(os, idx, s, o, p, pin_psi, cautious);
                     });
}

namespace {

// The fiber model's fused solve of one texel from `start` as it is; with pin_psi, psi held there;
// `cautious`: its first step damped kCautiousLambda (fiber_texel's retry).
constexpr double kPinWeight = 1e16;
TexelResult fiber_lm_from(const ObsSet& os, const std::vector<size_t>& idx,
                          const TexelResult& start, const TexelMapOptions& o,
                          const TexelPrior* prior, bool pin_psi, bool cautious) {
  TexelResult t = start;
  FiberAccuracy acc;
  acc.order = o.fiber_order;
  FusedSolve fs;
  FiberPull pull;
  if (prior) {
    for (int k = 0; k < 8; ++k) pull.w[k] = prior->w(k), pull.b[k] = prior->b(k);
    pull.w[8] = prior->ws, pull.b[8] = prior->bs;
  }
  // psi held: a pull on it alone so stiff that no step moves it (the solver takes the pull out
  // of its sum of squares and J^T J at the end).
  if (pin_psi) pull.w[7] = kPinWeight, pull.b[7] = t.c.psi;
  fiber_lm_solve(os, &idx, FitLoss::kNone, 0, o.max_iterations, 1, os.topology, acc, &t.c, &t.s,
                 &fs, prior || pin_psi ? &pull : nullptr, true, cautious ? kCautiousLambda : 0);
  const int P = os.topology == TopologyMode::kMathematical ? 8 : 9;
  const Eigen::MatrixXd info = Eigen::Map<const Eigen::MatrixXd>(fs.info.data(), P, P);
  texel_sigmas(info, fs.rss, 3.0 * idx.size(), &t, NoLobe::kHoldLobe);
  mark_converged(fs.converged, &t);
  return t;
}

}  // namespace

// One texel of the fiber model: fiber_texel_start, then the fiber model's fused solve
// (fit/solvers/fiber_solve.h: the global fit's solver, checked against Ceres there) on the texel
// alone, and from the start's other valley too.
TexelResult solve_texel_fiber(const ObsSet& os, const std::vector<size_t>& idx,
                              const TexelResult& from, const TexelMapOptions& o,
                              const TexelPrior* prior) {
  return fiber_texel(os, idx, from, o, prior,
                     [&](const TexelResult& s, const TexelPrior* p, bool pin_psi, bool cautious) {
                       return fiber_lm_from(os, idx, s, o, p, pin_psi, cautious);
                     });
}

bool fiber_order_holds(const ObsSet& os, const std::vector<size_t>& idx, const TexelResult& t,
                       int order, int reference, double allowed) {
  if (idx.empty() || order >= reference) return true;
  FiberAccuracy at, ref;
  at.order = order, ref.order = reference;
  const double c = std::cos(t.c.psi), sn = std::sin(t.c.psi), n = std::exp(t.c.logn);
  double sq = 0;
  for (size_t i : idx) {
    const Observation& ob = os.obs[i];
    const double si = pixel_topology(os, i, t.s);
    double d[3] = {0, 0, 0}, s[3] = {0, 0, 0}, dr[3] = {0, 0, 0}, sr[3] = {0, 0, 0};
    fiber_columns(os, ob, c, sn, n, si, at, d, s);
    fiber_columns(os, ob, c, sn, n, si, ref, dr, sr);
    for (int k = 0; k < 3; ++k) {
      const double e = t.c.kd[k] * (d[k] - dr[k]) + t.c.ks[k] * (s[k] - sr[k]);
      sq += e * e;
    }
  }
  return std::sqrt(sq / (3.0 * static_cast<double>(idx.size()))) <= allowed;
}

}  // namespace aniso::fitting
