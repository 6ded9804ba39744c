// The fiber model's part of a fit (docs/models.md §4): the line model's core plus the topology,
// which enters as one s for the whole sample, the amplitude A of a topology map over the per-pixel
// mathematical topology, the mathematical topology alone (nothing to fit), or an N x N map of s
// over uv (each pixel's s the bilinear mix of four texel parameters).
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/texture.h"
#include "fit/global/fiber_order.h"
#include "fit/solvers/fiber_solve.h"
#include "fit/solvers/start.h"
#include "models/fiber_model.h"
#include "models/params.h"

namespace aniso::fitting {

namespace {

// The fiber model's residual (docs/models.md §4): blocks kd 3, ks 3, log n 1, psi 1, topology 1
// (s, or the map amplitude A, or a constant dummy).
struct FiberResidual {
  FiberResidual(const ObsSet& os, size_t i, TopologyMode m, FiberAccuracy a)
      : obs(&os.obs[i]),
        lights(os.lights.data()),
        smath(os.smath(i)),
        mapv(os.mapv(i)),
        mode(m),
        acc(a) {}

  template <class T>
  bool operator()(const T* kd, const T* ks, const T* logn, const T* psi, const T* topo,
                  T* r) const {
    const LineParamsT<T> p = fitted_params(kd, ks, logn, psi);
    T s;
    switch (mode) {
      case TopologyMode::kGlobalS:
        s = topo[0];
        break;
      case TopologyMode::kAmplitude:
        s = topology_with_map(smath, topo[0], mapv);
        break;
      default:
        s = T(smath);
        break;
    }
    pixel_residual(
        obs, lights,
        [&](const LocalDir& L, const LocalDir& V, T* f) { fiber_reflectance(p, s, L, V, acc, f); },
        r);
    return true;
  }

  static ceres::CostFunction* Create(const ObsSet& os, size_t i, TopologyMode m, FiberAccuracy a) {
    return new ceres::AutoDiffCostFunction<FiberResidual, 3, 3, 3, 1, 1, 1>(
        new FiberResidual(os, i, m, a));
  }

  const Observation* obs;
  const ObsLight* lights;
  float smath, mapv;  // the pixel's topology (ObsSet::topo)
  TopologyMode mode;
  FiberAccuracy acc;
};

// The fiber model with a per-texel map of s: the pixel's s is the bilinear mix (wrap-around, glTF
// uv) of four texel parameters.
struct FiberTexelResidual {
  FiberTexelResidual(const Observation* o, const ObsLight* l, const BilinearTaps& t,
                     FiberAccuracy a)
      : obs(o), lights(l), taps(t), acc(a) {}

  template <class T>
  bool operator()(const T* kd, const T* ks, const T* logn, const T* psi, const T* t0, const T* t1,
                  const T* t2, const T* t3, T* r) const {
    const LineParamsT<T> p = fitted_params(kd, ks, logn, psi);
    const T s = taps.weight[0] * t0[0] + taps.weight[1] * t1[0] + taps.weight[2] * t2[0] +
                taps.weight[3] * t3[0];
    pixel_residual(
        obs, lights,
        [&](const LocalDir& L, const LocalDir& V, T* f) { fiber_reflectance(p, s, L, V, acc, f); },
        r);
    return true;
  }

  static ceres::CostFunction* Create(const Observation* o, const ObsLight* l, const BilinearTaps& t,
                                     FiberAccuracy a) {
    return new ceres::AutoDiffCostFunction<FiberTexelResidual, 3, 3, 3, 1, 1, 1, 1, 1, 1>(
        new FiberTexelResidual(o, l, t, a));
  }

  const Observation* obs;
  const ObsLight* lights;
  BilinearTaps taps;
  FiberAccuracy acc;
};

class FiberFit : public ModelFit {
 public:
  FiberFit(const FitOptions& opt, const ObsSet& os) : mode_(os.topology), texels_n_(os.texels) {
    acc_.order = opt.fiber_order;
  }

  Model model() const override { return Model::kFiber; }
  size_t parameters() const override {
    const size_t n = static_cast<size_t>(texels_n_);
    return 8 + (mode_ == TopologyMode::kTexels ? n * n : fitted_topology() ? 1 : 0);
  }

  // From the line grid's (psi, n), a search over the topology (s in 0.05..0.95, or A in -1..1)
  // at the line's n, then over n around it at the best topology, k_d, k_s solved in closed form
  // at every node (the nodes in parallel, each alone: the same start on any number of threads;
  // the specular integral at order 4, plenty to rank nodes). Then the quadrature order.
  std::string start(const ObsSet& os, const ProgressSink* progress) override {
    const std::string line = line_grid_start(os, &core, progress, &other);
    const std::vector<size_t> subset = start_subset(os.obs.size(), kMaxStartObs);
    std::vector<double> topo_values;
    if (mode_ == TopologyMode::kGlobalS || mode_ == TopologyMode::kTexels)
      for (int i = 0; i < 10; ++i) topo_values.push_back(0.05 + 0.1 * i);
    else if (mode_ == TopologyMode::kAmplitude)
      for (int i = 0; i <= 8; ++i) topo_values.push_back(-1.0 + 0.25 * i);
    else
      topo_values.push_back(0.0);
    const double c = std::cos(core.psi), sn = std::sin(core.psi), logn0 = core.logn;
    struct Node {
      double t, logn, cost, kd[3], ks[3];
    };
    FiberAccuracy grid_acc;
    grid_acc.order = std::min(4, acc_.order > 0 ? acc_.order : 4);
    auto solve_nodes = [&](std::vector<Node>* nodes) {
      tbb::parallel_for(size_t(0), nodes->size(), [&](size_t k) {
        Node& node = (*nodes)[k];
        const double n = std::exp(node.logn);
        node.cost = solve_kd_ks(
            os, subset,
            [&](size_t i, const Observation& o, double* dcol, double* scol) {
              fiber_columns(os, o, c, sn, n, pixel_s(os, i, node.t), grid_acc, dcol, scol);
            },
            node.kd, node.ks);
      });
      size_t best = 0;
      for (size_t k = 1; k < nodes->size(); ++k)
        if ((*nodes)[k].cost < (*nodes)[best].cost) best = k;
      return (*nodes)[best];
    };
    // The topology at the line grid's n, then n half and twice (e^-0.7, e^0.7) at the best
    // topology: 12 nodes where the full 3 x 10 grid took 30, and the same starts on the test sets.
    std::vector<Node> by_topology;
    for (double t : topo_values) by_topology.push_back(Node{t, logn0, 0, {}, {}});
    Node best = solve_nodes(&by_topology);
    std::vector<Node> by_n = {Node{best.t, logn0 - 0.7, 0, {}, {}},
                              Node{best.t, logn0 + 0.7, 0, {}, {}}};
    const Node by_n_best = solve_nodes(&by_n);
    if (by_n_best.cost < best.cost) best = by_n_best;
    const double best_t = best.t;
    topo_[0] = best_t;
    if (mode_ == TopologyMode::kTexels)
      texels_.assign(static_cast<size_t>(texels_n_) * texels_n_, best_t);
    core.logn = best.logn;
    set_start_kd_ks(best.kd, best.ks, &core);
    // The second look (fit/global/solve.cpp) from the other valley's psi with the topology, n, k_d
    // and k_s found here: a mirror (psi -> -psi) looks the same to them.
    if (other) {
      const double psi_other = other->psi;
      other = core;
      other->psi = psi_other;
    }
    char buf[300];
    std::snprintf(buf, sizeof buf, "; fiber: topology %s=%.2f, n=%.0f (%zu + 2 nodes)",
                  mode_ == TopologyMode::kAmplitude ? "A" : "s", best_t, std::exp(core.logn),
                  topo_values.size());
    return line + buf + choose_order(os, subset);
  }

  void add_residuals(ceres::Problem* pb, const ObsSet& os, const std::vector<size_t>& idx,
                     ceres::LossFunction* loss) override {
    if (mode_ == TopologyMode::kTexels) {
      for (size_t i : idx) {
        const BilinearTaps t = bilinear_wrap(os.uv[2 * i], os.uv[2 * i + 1], texels_n_, texels_n_);
        pb->AddResidualBlock(FiberTexelResidual::Create(&os.obs[i], os.lights.data(), t, acc_),
                             loss, core.kd, core.ks, &core.logn, &core.psi, &texels_[t.index[0]],
                             &texels_[t.index[1]], &texels_[t.index[2]], &texels_[t.index[3]]);
      }
      for (double& t : texels_)
        if (pb->HasParameterBlock(&t)) set_param_bounds(pb, &t, 0, "topology.s");
    } else {
      for (size_t i : idx)
        pb->AddResidualBlock(FiberResidual::Create(os, i, mode_, acc_), loss, core.kd, core.ks,
                             &core.logn, &core.psi, topo_);
      if (fitted_topology())
        set_param_bounds(pb, topo_, 0, topology_key());
      else
        pb->SetParameterBlockConstant(topo_);
    }
    set_core_bounds(pb, &core);
  }

  // The fused solve (fit/solvers/fiber_solve.h) for every topology but a texel map, unless Ceres is
  // asked.
  bool solve_fused(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss, double scale,
                   const FitOptions& opt, FusedSolve* out) override {
    if (mode_ == TopologyMode::kTexels || opt.ceres_solver || opt.ceres_covariance) return false;
    fiber_lm_solve(os, subset, loss, scale, opt.max_iterations, opt.threads, mode_, acc_, &core,
                   topo_, out, nullptr, false, 0, opt.progress);
    out->order = {{core.kd, 3}, {core.ks, 3}, {&core.logn, 1}, {&core.psi, 1}};
    if (fitted_topology()) out->order.push_back({topo_, 1});
    return true;
  }

  double topology_value() const override { return topo_[0]; }
  std::vector<double> own() const override {
    std::vector<double> v = texels_;
    v.push_back(topo_[0]);
    return v;
  }
  void set_own(const std::vector<double>& v) override {
    topo_[0] = v.back();
    texels_.assign(v.begin(), v.end() - 1);
  }
  int quadrature_order() const override { return acc_.order; }
  FiberOrderErrors quadrature_errors() const override { return order_errors_; }

  void residual(const ObsSet& os, size_t i, double r[3]) const override {
    const FiberResidual f(os, i, mode_, acc_);
    f(core.kd, core.ks, &core.logn, &core.psi, topo_, r);
  }
  bool residual_row(const ObsSet& os, size_t i, double r[3], double dkd[3], double dks[3],
                    double shared[3][3]) const override {
    if (mode_ == TopologyMode::kTexels) return false;
    fiber_row(os, i, mode_, acc_, core, topo_[0], r, dkd, dks, shared);
    return true;
  }
  std::vector<const double*> row_shared() const override {
    if (mode_ == TopologyMode::kTexels) return {};
    std::vector<const double*> v = {&core.logn, &core.psi};
    if (mode_ != TopologyMode::kMathematical) v.push_back(topo_);
    return v;
  }

  std::vector<Block> blocks(ceres::Problem* pb) override {
    std::vector<Block> b;
    if (mode_ == TopologyMode::kTexels) {
      for (double& t : texels_)
        if (pb->HasParameterBlock(&t)) b.push_back({&t, 1, {}});
    } else if (fitted_topology()) {
      b.push_back(
          {topo_, 1, {mode_ == TopologyMode::kGlobalS ? "topology.s" : "topology.amplitude"}});
    }
    return b;
  }
  bool full_correlation() const override { return mode_ != TopologyMode::kTexels; }

  void sigmas(const SigmaOf& sigma, ceres::Problem* pb, FitResult* res) const override {
    // A topology this uncertain is not measured: flat-looking data, or s near the s = 0 = 1 seam.
    constexpr double kTopologyUndetermined = 0.25;
    if (mode_ == TopologyMode::kTexels) {
      res->s_texels = texels_;
      res->s_texel_sigma.assign(texels_.size(), -1.0);
      size_t undetermined = 0;
      for (size_t i = 0; i < texels_.size(); ++i) {
        double* t = const_cast<double*>(&texels_[i]);
        const double sd = pb->HasParameterBlock(t) ? sigma(t, 1)[0] : -1.0;
        if (std::isfinite(sd) && sd >= 0 && sd <= kTopologyUndetermined)
          res->s_texel_sigma[i] = sd;
        else
          ++undetermined;
      }
      if (undetermined)
        res->undetermined["topology.s_map"] =
            std::to_string(undetermined) + " of " + std::to_string(texels_.size()) +
            " texels are not determined (no pixel covers them, or too few do); their "
            "sigma is written as -1";
    } else if (fitted_topology()) {
      const double sd = sigma(topo_, 1)[0];
      if (sd > kTopologyUndetermined)
        res->undetermined[topology_key()] =
            "sigma " + std::to_string(sd) + ": the data barely constrain the topology";
      else
        res->sigma[topology_key()] = {sd};
    }
  }

  void assemble(const ObsSet& os, FitResult* res) const override {
    Material& mat = res->material;
    mat.model = Model::kFiber;
    switch (mode_) {
      case TopologyMode::kGlobalS:
        mat.topology = UniformS{topo_[0]};
        break;
      case TopologyMode::kAmplitude:
        mat.topology = TopologyMapRef{os.topology_map, topo_[0], os.topology_mathematical};
        break;
      case TopologyMode::kMathematical:
        mat.topology = MathematicalS{os.topology_mathematical};
        res->fixed["topology"] =
            "taken from the capture's mathematical topology buffer (no map to fit)";
        break;
      case TopologyMode::kTexels:
        mat.topology = SMapRef{};  // the file is named when the material is written
        res->s_texels_n = texels_n_;
        break;
    }
    res->fixed["isotropic"] = "not fitted (absent; the fiber model has no isotropic term)";
    res->fixed["second_fiber"] = "not fitted (absent; the fiber model has one fiber direction)";
  }

 private:
  bool fitted_topology() const { return mode_ != TopologyMode::kMathematical; }
  const char* topology_key() const {
    return mode_ == TopologyMode::kAmplitude ? "topology.amplitude" : "topology.s";
  }
  // --fiber-order, or (0) the smallest order whose quadrature error cannot move the fit
  // (fit/global/fiber_order.h); the start's note says which and why.
  std::string choose_order(const ObsSet& os, const std::vector<size_t>& subset) {
    if (acc_.order > 0) return "; quadrature order " + std::to_string(acc_.order) + " (as given)";
    const FiberOrderChoice ch =
        choose_fiber_order(os, subset, core, [&](size_t i) { return pixel_s(os, i, topo_[0]); });
    acc_.order = ch.order;
    order_errors_ = ch.errors;
    return ch.note;
  }

  // s at an observation for the topology value t (s or A) of the start grid.
  double pixel_s(const ObsSet& os, size_t i, double t) const {
    if (mode_ == TopologyMode::kAmplitude) return topology_with_map(os.smath(i), t, os.mapv(i));
    if (mode_ == TopologyMode::kMathematical) return os.smath(i);
    return t;
  }

  const TopologyMode mode_;
  const int texels_n_;
  FiberAccuracy acc_;
  FiberOrderErrors order_errors_;
  double topo_[1] = {0.5};      // s or the map amplitude A
  std::vector<double> texels_;  // kTexels: N x N values of s
};

}  // namespace

ceres::CostFunction* fiber_pixel_cost(const ObsSet& os, size_t i, TopologyMode mode,
                                      const FiberAccuracy& acc) {
  return FiberResidual::Create(os, i, mode, acc);
}

std::unique_ptr<ModelFit> make_fiber_fit(const FitOptions& opt, const ObsSet& os) {
  return std::make_unique<FiberFit>(opt, os);
}

}  // namespace aniso::fitting
