#include "fit/solvers/fiber_solve.h"

#include <ceres/jet.h>

#include <cstdio>
#include <type_traits>

#include "core/progress.h"
#include "fit/solvers/fused_lm.h"
#include "fit/solvers/line_solve.h"
#include "models/params.h"

namespace aniso::fitting {

namespace {

using J3 = ceres::Jet<double, 3>;  // d/d(log n, psi, topology)

// The fiber model at x (P = 9: the topology is x(8); P = 8: the mathematical topology).
template <int P>
struct FiberPass {
  const ObsSet& os;
  const std::vector<size_t>* subset;
  TopologyMode mode;
  FiberAccuracy acc;

  // The solve's numbers at x, with log n, psi and the topology as the Jets' three variables.
  struct At {
    double kd[3], ks[3];
    J3 n, c, sn, topo;
  };
  static At at(const VecP<P>& x) {
    const J3 psi(x(7), 1);
    return {{x(0), x(1), x(2)}, {x(3), x(4), x(5)}, exp(J3(x(6), 0)),
            cos(psi),           sin(psi),           P == 9 ? J3(x(P - 1), 2) : J3(0.0)};
  }

  // Observation i's rows at a.
  void pixel(const At& a, size_t i, ObsRow<P>* d) const {
    const J3 s = mode == TopologyMode::kGlobalS ? a.topo
                 : mode == TopologyMode::kAmplitude
                     ? topology_with_map(os.smath(i), a.topo, os.mapv(i))
                     : J3(os.smath(i));
    row(os.obs[i], a.kd, a.ks, a.n, a.c, a.sn, s, d);
  }

  FusedSums<P> operator()(const VecP<P>& x, const RobustLoss& loss, bool jac,
                          tbb::task_arena* arena) const {
    const At a = at(x);
    const size_t count = subset ? subset->size() : os.obs.size();
    return fused_pass<P>(count, loss, jac, arena,
                         [&](size_t j, ObsRow<P>* d) { pixel(a, subset ? (*subset)[j] : j, d); });
  }

  // One pixel: r_k and its rows, as fiber_reflectance (models/fiber_model.h) computes it.
  void row(const Observation& o, const double kd[3], const double ks[3], const J3& n, const J3& c,
           const J3& sn, const J3& s, ObsRow<P>* d) const {
    const LocalDir& V = o.V;
    for (int k = 0; k < 3; ++k) {
      d->r[k] = -double(o.y[k]);
      d->dkd[k] = d->dks[k] = 0;
      for (int j = 0; j < P - 6; ++j) d->shared[k][j] = 0;
    }
    if (V.n < -kHorizonRounding) return;
    const J3 b = c * V.u + sn * V.w, vb = c * V.w - sn * V.u;
    for (uint32_t i = 0; i < o.num_lights; ++i) {
      const ObsLight& l = os.lights[o.first_light + i];
      const LocalDir L = l.L;
      if (L.n < -kHorizonRounding) continue;
      J3 D, S;
      fiber_DS(c * L.w - sn * L.u, J3(L.n), vb, J3(V.n), c * L.u + sn * L.w, b, n, s, acc, &D, &S);
      for (int k = 0; k < 3; ++k) {
        const double E = l.E[k];
        d->r[k] += E * (kd[k] * D.a + ks[k] * S.a);
        d->dkd[k] += E * D.a;
        d->dks[k] += E * S.a;
        for (int j = 0; j < P - 6; ++j) d->shared[k][j] += E * (kd[k] * D.v[j] + ks[k] * S.v[j]);
      }
    }
  }
};

// The pull's cost at x, and (with `s`) its terms added to the sums of a pass.
template <int P>
double add_pull(const FiberPull& pull, const VecP<P>& x, FusedSums<P>* s) {
  double cost = 0;
  for (int k = 0; k < P; ++k) {
    const double d = k == 7 ? std::remainder(x(k) - pull.b[k], M_PI) : x(k) - pull.b[k];
    cost += pull.w[k] * d * d;
    if (!s) continue;
    s->H(k, k) += pull.w[k];
    s->g(k) += pull.w[k] * d;
  }
  if (s) s->cost += cost, s->rss += cost;
  return cost;
}

template <int P>
void solve(const ObsSet& os, const std::vector<size_t>* subset, const RobustLoss& loss,
           int max_iterations, int threads, TopologyMode mode, const FiberAccuracy& acc, Core* c,
           double* topo, FusedSolve* out, const FiberPull* pull, bool ridge_rule, double lambda0,
           const ProgressSink* progress) {
  tbb::task_arena arena(std::max(1, threads));
  const FiberPass<P> pass{os, subset, mode, acc};
  VecP<P> lo, hi, x;
  Vec8 lo8, hi8;
  core_bounds(&lo8, &hi8);
  lo.template head<8>() = lo8;
  hi.template head<8>() = hi8;
  x.template head<8>() = pack_core(*c);
  if constexpr (P == 9) {
    const ParamSpec& t =
        line_param(mode == TopologyMode::kAmplitude ? "topology.amplitude" : "topology.s");
    lo(8) = t.lo, hi(8) = t.hi, x(8) = *topo;
  }
  const double values = 3.0 * static_cast<double>(subset ? subset->size() : os.obs.size());
  FusedSums<P> cur;
  int passes = 0;
  auto evaluate = [&](const VecP<P>& at, bool jac) {
    FusedSums<P> s = pass(at, loss, jac, &arena);
    if (pull) add_pull<P>(*pull, at, &s);
    if (progress) {
      char line[120];
      std::snprintf(line, sizeof line, "fit: fiber model, pass %d over %.0f values, cost %.6g",
                    ++passes, values, s.cost);
      progress->status(line);
    }
    return s;
  };
  fused_lm<P>(evaluate, lo, hi, values, max_iterations, &x, &cur, out, ridge_rule,
              lambda0 > 0 ? lambda0 : NielsenDamping().lambda);
  if (pull) {  // the data's own J^T J and sum of squares at the solution
    out->rss -= add_pull<P>(*pull, x, nullptr);
    for (int k = 0; k < P; ++k) out->info[static_cast<size_t>(k) * (P + 1)] -= pull->w[k];
  }
  unpack_core(x.template head<8>(), c);
  if constexpr (P == 9) *topo = x(8);
}

}  // namespace

void fiber_row(const ObsSet& os, size_t i, TopologyMode mode, const FiberAccuracy& acc,
               const Core& c, double topo, double r[3], double dkd[3], double dks[3],
               double shared[3][3]) {
  auto one = [&](auto p) {
    constexpr int P = decltype(p)::value;
    VecP<P> x;
    x.template head<8>() = pack_core(c);
    if constexpr (P == 9) x(8) = topo;
    const FiberPass<P> pass{os, nullptr, mode, acc};
    ObsRow<P> d;
    pass.pixel(FiberPass<P>::at(x), i, &d);
    for (int k = 0; k < 3; ++k) {
      r[k] = d.r[k], dkd[k] = d.dkd[k], dks[k] = d.dks[k];
      for (int j = 0; j < 3; ++j) shared[k][j] = j < P - 6 ? d.shared[k][j] : 0.0;
    }
  };
  if (mode == TopologyMode::kMathematical)
    one(std::integral_constant<int, 8>());
  else
    one(std::integral_constant<int, 9>());
}

void fiber_lm_solve(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss, double scale,
                    int max_iterations, int threads, TopologyMode mode, const FiberAccuracy& acc,
                    Core* c, double* topo, FusedSolve* out, const FiberPull* pull, bool ridge_rule,
                    double lambda0, const ProgressSink* progress) {
  const RobustLoss l{loss, scale};
  if (mode == TopologyMode::kMathematical)
    solve<8>(os, subset, l, max_iterations, threads, mode, acc, c, topo, out, pull, ridge_rule,
             lambda0, progress);
  else
    solve<9>(os, subset, l, max_iterations, threads, mode, acc, c, topo, out, pull, ridge_rule,
             lambda0, progress);
}

}  // namespace aniso::fitting
