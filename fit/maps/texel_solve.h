// fit/ internal: one texel of --maps solved (fit/maps/texel_line.cpp) for fit_texel_maps
// (fit/maps/maps.cpp): the line model by a hand-written Levenberg-Marquardt (float lanes, then
// double) or by Ceres, the fiber model by its fused solver or by Ceres; each with the texel's
// sigmas from its own normal equations and the verdict whether its data determine it.
#pragma once
#include <vector>

#include "fit/maps/maps.h"
#include "fit/solvers/line_solve.h"

namespace aniso::fitting {

// The parameter a fiber texel fits beside the core: s, or a topology map's amplitude A.
inline const char* texel_topology_key(TopologyMode mode) {
  return mode == TopologyMode::kAmplitude ? "topology.amplitude" : "topology.s";
}

struct TexelResult {
  Core c;
  double s = 0;                                   // the fiber model's topology
  double sigma[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};  // kd 3, ks 3, log n, psi (, s)
  bool determined = false;
  // The solver reached a minimum. A texel whose solver stopped at its iteration limit is not
  // determined either: its numbers may be anywhere on the way.
  bool converged = true;
  double rss = 0, values = 0;
  int quadrature_order = 0;  // a fiber texel's (fit/maps/maps.cpp: its own values', checked)
};

// --smooth: a quadratic pull of x toward b with weights w (diagonal), added to the texel's sum
// of squares; psi's difference taken modulo a half turn.
struct TexelPrior {
  Vec8 w = Vec8::Zero(), b = Vec8::Zero();
  double ws = 0, bs = 0;  // the fiber model's topology s (where fitted)
};

// Solves the texel of observations idx from `from` (with `prior`: pulled toward its neighbours,
// started where it is; without: started from its own grid over psi).
// `wide`: the float passes sixteen lanes at a time where the CPU has AVX-512 (texel_lanes.h).
TexelResult solve_texel_lm(const ObsSet& os, const std::vector<size_t>& idx, const Core& from,
                           const TexelPrior* prior, int max_iterations = kTexelIterations,
                           bool wide = false);
TexelResult solve_texel_ceres(const ObsSet& os, const std::vector<size_t>& idx, const Core& from,
                              const TexelPrior* prior, int max_iterations = kTexelIterations,
                              bool wide = false);
TexelResult solve_texel_fiber(const ObsSet& os, const std::vector<size_t>& idx,
                              const TexelResult& from, const TexelMapOptions& o,
                              const TexelPrior* prior);
TexelResult solve_texel_fiber_ceres(const ObsSet& os, const std::vector<size_t>& idx,
                                    const TexelResult& from, const TexelMapOptions& o,
                                    const TexelPrior* prior);

// Whether a fiber texel solved at quadrature order `order` holds at its own solution t: the RMS per
// value of its model's difference from the model at order `reference`, over its observations,
// within `allowed` (the global fit's errors per order were measured at its own lobe; a texel's
// own may need more nodes).
bool fiber_order_holds(const ObsSet& os, const std::vector<size_t>& idx, const TexelResult& t,
                       int order, int reference, double allowed);

}  // namespace aniso::fitting
