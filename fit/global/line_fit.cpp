// The line-lighting model's part of a fit (docs/models.md §3): the plain model with hand-written
// derivatives (one block per pixel, or chunks of 256 pixels with reweighting for the robust
// loss), and the optional isotropic and second-fiber terms with automatic derivatives.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/angles.h"
#include "fit/solvers/isotropic_pixel.h"
#include "fit/solvers/line_pixel.h"
#include "fit/solvers/line_solve.h"
#include "fit/solvers/start.h"
#include "models/params.h"
#include "models/safe_math.h"

namespace aniso::fitting {

namespace {

// The residual of one pixel: exposure * I(params) - y, per channel (docs/models.md §2-3).
// Block sizes: kd 3, ks 3, log n 1, psi 1, isotropic (kd 3, ks 3, log n_iso 1) or a 1-wide dummy,
// second fiber (psi2, w) or a 1-wide dummy. Dummies are held constant.
template <bool kIso, bool kSecond>
struct LineResidual {
  LineResidual(const Observation* o, const ObsLight* l) : obs(o), lights(l) {}

  template <class T>
  bool operator()(const T* kd, const T* ks, const T* logn, const T* psi, const T* iso, const T* sec,
                  T* r) const {
    using std::exp;
    LineParamsT<T> p = fitted_params(kd, ks, logn, psi);
    p.isotropic = kIso;
    p.second = kSecond;
    if constexpr (kIso) {
      for (int k = 0; k < 3; ++k) {
        p.kd_iso[k] = iso[k];
        p.ks_iso[k] = iso[3 + k];
      }
      p.n_iso = exp(iso[6]);
    }
    if constexpr (kSecond) {
      p.psi2 = sec[0];
      p.w = sec[1];
    }
    pixel_residual(
        obs, lights,
        [&](const LocalDir& L, const LocalDir& V, T* f) { line_reflectance(p, L, V, f); }, r);
    return true;
  }

  static ceres::CostFunction* Create(const Observation* o, const ObsLight* l) {
    return new ceres::AutoDiffCostFunction < LineResidual, 3, 3, 3, 1, 1, kIso ? 7 : 1,
           kSecond ? 2 : 1 > (new LineResidual(o, l));
  }

  const Observation* obs;
  const ObsLight* lights;
};

// The common case (no optional terms) with hand-written derivatives (fit/solvers/line_pixel.h): the
// same residual as LineResidual<false, false>, about 4x cheaper than Jets of size 8 (tests compare
// the two).
class LineResidualAnalytic : public ceres::SizedCostFunction<3, 3, 3, 1, 1, 1, 1> {
 public:
  LineResidualAnalytic(const Observation* o, const ObsLight* l) : obs_(o), lights_(l) {}

  bool Evaluate(double const* const* p, double* r, double** J) const override {
    PixelDerivs d;
    line_pixel_derivs(*obs_, lights_, p[0], p[1], p[2][0], p[3][0], &d);
    for (int k = 0; k < 3; ++k) r[k] = d.r[k];
    if (!J) return true;
    if (J[0]) std::fill(J[0], J[0] + 9, 0.0);
    if (J[1]) std::fill(J[1], J[1] + 9, 0.0);
    for (int k = 0; k < 3; ++k) {
      if (J[0]) J[0][k * 3 + k] = d.dkd[k];
      if (J[1]) J[1][k * 3 + k] = d.dks[k];
      if (J[2]) J[2][k] = d.dlogn[k];
      if (J[3]) J[3][k] = d.dpsi[k];
      if (J[4]) J[4][k] = 0;
      if (J[5]) J[5][k] = 0;
    }
    return true;
  }

 private:
  const Observation* obs_;
  const ObsLight* lights_;
};

// The line model with its isotropic part (--fit-isotropic, no second fiber) with hand-written
// derivatives (fit/solvers/isotropic_pixel.h): the same residual as LineResidual<true, false>
// (tests compare the two), without Jets of 15. Blocks as LineResidual's, the last a dummy.
class LineIsotropicAnalytic : public ceres::SizedCostFunction<3, 3, 3, 1, 1, kIsotropicParams, 1> {
 public:
  LineIsotropicAnalytic(const ObsSet* os, size_t i) : os_(os), i_(i) {}

  bool Evaluate(double const* const* p, double* r, double** J) const override {
    line_isotropic_pixel(*os_, i_, p[0], p[1], p[2][0], p[3][0], p[4], r, J);
    if (J && J[5])
      for (int k = 0; k < 3; ++k) J[5][k] = 0;
    return true;
  }

 private:
  const ObsSet* os_;
  size_t i_;
};

// Many pixels per residual block (the default line fit): per-block overhead in Ceres, not the
// model, dominated the per-pixel form. Each pixel's three residuals are scaled by sqrt(w_i), the
// weight of iteratively reweighted least squares that reproduces the robust loss per pixel.
class LineChunkResidual : public ceres::CostFunction {
 public:
  LineChunkResidual(std::vector<const Observation*> obs, const ObsLight* lights,
                    const std::vector<double>* sqrt_w, size_t first)
      : obs_(std::move(obs)), lights_(lights), sqrt_w_(sqrt_w), first_(first) {
    set_num_residuals(static_cast<int>(3 * obs_.size()));
    *mutable_parameter_block_sizes() = {3, 3, 1, 1};
  }
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const double dummy_iso = 0, dummy_sec = 0;
    const double* params[6] = {p[0], p[1], p[2], p[3], &dummy_iso, &dummy_sec};
    const int m = num_residuals();
    for (size_t i = 0; i < obs_.size(); ++i) {
      const LineResidualAnalytic one(obs_[i], lights_);
      double ri[3], j0[9], j1[9], j2[3], j3[3];
      double* jac[6] = {j0, j1, j2, j3, nullptr, nullptr};
      one.Evaluate(params, ri, J ? jac : nullptr);
      const double w = (*sqrt_w_)[first_ + i];
      for (int k = 0; k < 3; ++k) r[3 * i + k] = w * ri[k];
      if (!J) continue;
      for (int k = 0; k < 3; ++k) {
        const size_t row = 3 * i + k;
        if (J[0])
          for (int q = 0; q < 3; ++q) J[0][row * 3 + q] = w * j0[k * 3 + q];
        if (J[1])
          for (int q = 0; q < 3; ++q) J[1][row * 3 + q] = w * j1[k * 3 + q];
        if (J[2]) J[2][row] = w * j2[k];
        if (J[3]) J[3][row] = w * j3[k];
      }
    }
    (void)m;
    return true;
  }

 private:
  std::vector<const Observation*> obs_;
  const ObsLight* lights_;
  const std::vector<double>* sqrt_w_;
  size_t first_;
};

class LineFit : public ModelFit {
 public:
  explicit LineFit(const FitOptions& opt)
      : iso_(opt.fit_isotropic),
        second_(opt.fit_second),
        chunked_(opt.chunked),
        hold_psi_(opt.hold_psi_deg.has_value()),
        held_psi_(opt.hold_psi_deg ? deg_to_rad(*opt.hold_psi_deg) : 0.0) {}

  Model model() const override { return Model::kLine; }
  size_t parameters() const override { return 8 + (iso_ ? 7 : 0) + (second_ ? 2 : 0); }

  std::string start(const ObsSet& os, const ProgressSink* progress) override {
    // The second look only where the core is all there is (optional terms start from the core).
    std::string s =
        line_grid_start(os, &core, progress, iso_ || second_ || hold_psi_ ? nullptr : &other);
    if (hold_psi_) {
      core.psi = held_psi_;
      s += "; psi held at " + std::to_string(rad_to_deg(held_psi_)) + " deg";
    }
    sec_[0] = wrap_half_turn(core.psi + M_PI / 2);
    return s;
  }

  void add_residuals(ceres::Problem* pb, const ObsSet& os, const std::vector<size_t>& idx,
                     ceres::LossFunction* loss) override {
    if (iso_ && second_)
      add_blocks<true, true>(pb, os, idx, loss);
    else if (iso_)
      add_blocks<true, false>(pb, os, idx, loss);
    else if (second_)
      add_blocks<false, true>(pb, os, idx, loss);
    else
      add_blocks<false, false>(pb, os, idx, loss);
    set_core_bounds(pb, &core);
    if (hold_psi_) pb->SetParameterBlockConstant(&core.psi);
    if (iso_) {
      for (int k = 0; k < 3; ++k) {
        set_param_bounds(pb, iso_block_, k, "isotropic.kd");
        set_param_bounds(pb, iso_block_, 3 + k, "isotropic.ks");
      }
      set_param_bounds(pb, iso_block_, 6, "isotropic.n");
    } else {
      pb->SetParameterBlockConstant(dummy_iso_);
    }
    if (second_)
      set_param_bounds(pb, sec_, 1, "second_fiber.weight");
    else
      pb->SetParameterBlockConstant(dummy_sec_);
  }

  bool add_reweighted(ceres::Problem* pb, const ObsSet& os,
                      const std::vector<double>* sqrt_w) override {
    if (iso_ || second_ || !chunked_) return false;
    constexpr size_t kChunk = 256;
    for (size_t c0 = 0; c0 < os.obs.size(); c0 += kChunk) {
      std::vector<const Observation*> chunk;
      for (size_t i = c0; i < std::min(os.obs.size(), c0 + kChunk); ++i)
        chunk.push_back(&os.obs[i]);
      pb->AddResidualBlock(new LineChunkResidual(std::move(chunk), os.lights.data(), sqrt_w, c0),
                           nullptr, core.kd, core.ks, &core.logn, &core.psi);
    }
    set_core_bounds(pb, &core);
    if (hold_psi_) pb->SetParameterBlockConstant(&core.psi);
    return true;
  }

  bool solve_fused(const ObsSet& os, const std::vector<size_t>* subset, FitLoss loss, double scale,
                   const FitOptions& opt, FusedSolve* out) override {
    if (iso_ || second_ || !chunked_ || opt.ceres_solver || opt.ceres_covariance) return false;
    line_lm_solve(os, subset, loss, scale, opt.max_iterations, opt.threads, &core, out, hold_psi_);
    out->order = {{core.kd, 3}, {core.ks, 3}, {&core.logn, 1}, {&core.psi, 1}};
    return true;
  }

  // The whole model's, optional terms included: the views' spread (fit/global/view_sandwich.h)
  // differentiates it.
  void residual(const ObsSet& os, size_t i, double r[3]) const override {
    const Observation* o = &os.obs[i];
    const double* c[4] = {core.kd, core.ks, &core.logn, &core.psi};
    if (iso_ && second_) {
      LineResidual<true, true>(o, os.lights.data())(c[0], c[1], c[2], c[3], iso_block_, sec_, r);
      return;
    }
    if (iso_) {
      line_isotropic_pixel(os, i, core.kd, core.ks, core.logn, core.psi, iso_block_, r, nullptr);
      return;
    }
    if (second_) {
      LineResidual<false, true>(o, os.lights.data())(c[0], c[1], c[2], c[3], dummy_iso_, sec_, r);
      return;
    }
    const LineResidualAnalytic one(o, os.lights.data());
    const double dummy = 0;
    const double* params[6] = {core.kd, core.ks, &core.logn, &core.psi, &dummy, &dummy};
    one.Evaluate(params, r, nullptr);
  }

  // An isotropic lobe of zero weight leaves n_iso free, a second fiber of zero weight (w -> 1)
  // leaves its angle free: hold the free coordinate (a subset manifold), name it, and keep
  // everyone else's sigma.
  void hold_undetermined(ceres::Problem* pb, double kd_max, FitResult* res) override {
    if (hold_psi_ && pb->HasParameterBlock(&core.psi)) pb->SetParameterBlockConstant(&core.psi);
    if (iso_) {
      const double iso_ks = std::max({iso_block_[3], iso_block_[4], iso_block_[5]});
      if (!(iso_ks > kKsNegligible * std::max(1.0, kd_max))) {
        iso_n_free_ = false;
        res->undetermined["isotropic.n"] =
            "the isotropic specular k_s,iso is about 0 (" + std::to_string(iso_ks) +
            "): no isotropic lobe to measure n_iso from (the data show no isotropic term)";
        pb->SetManifold(iso_block_, new ceres::SubsetManifold(7, {6}));
      }
    }
    if (second_) {
      constexpr double kWeightNegligible = 1e-4;  // of the second lobe: 1 - w
      if (!(1.0 - sec_[1] > kWeightNegligible)) {
        sec_angle_free_ = false;
        res->undetermined["second_fiber.angle_deg"] =
            "the second fiber's weight 1 - w is about 0: no second lobe to measure its angle from";
        pb->SetManifold(sec_, new ceres::SubsetManifold(2, {0}));
      }
    }
  }

  std::vector<Block> blocks(ceres::Problem*) override {
    std::vector<Block> b;
    if (iso_)
      b.push_back({iso_block_,
                   7,
                   {"isotropic.kd.r", "isotropic.kd.g", "isotropic.kd.b", "isotropic.ks.r",
                    "isotropic.ks.g", "isotropic.ks.b", "isotropic.log n"}});
    if (second_) b.push_back({sec_, 2, {"second_fiber.angle", "second_fiber.weight"}});
    return b;
  }

  void sigmas(const SigmaOf& sigma, ceres::Problem*, FitResult* res) const override {
    if (iso_) {
      const auto d = sigma(iso_block_, 7);
      res->sigma["isotropic.kd"] = {d[0], d[1], d[2]};
      res->sigma["isotropic.ks"] = {d[3], d[4], d[5]};
      if (iso_n_free_) res->sigma["isotropic.n"] = {std::exp(iso_block_[6]) * d[6]};
    }
    if (second_) {
      const auto d = sigma(sec_, 2);
      if (sec_angle_free_) res->sigma["second_fiber.angle_deg"] = {rad_to_deg(d[0])};
      res->sigma["second_fiber.weight"] = {d[1]};
    }
  }

  void assemble(const ObsSet&, FitResult* res) const override {
    Material& mat = res->material;
    mat.model = Model::kLine;
    if (iso_) {
      mat.has_isotropic = true;
      for (int k = 0; k < 3; ++k) {
        mat.iso_kd[k] = iso_block_[k];
        mat.iso_ks[k] = iso_block_[3 + k];
      }
      mat.iso_n = std::exp(iso_block_[6]);
    } else {
      res->fixed["isotropic"] = "not fitted (absent; pass --fit-isotropic to fit it)";
    }
    if (second_) {
      mat.has_second_fiber = true;
      mat.second_angle_deg = wrap_fiber_deg(rad_to_deg(sec_[0]));
      mat.second_weight = sec_[1];
    } else {
      res->fixed["second_fiber"] = "not fitted (absent; pass --fit-second-fiber to fit it)";
    }
  }

 private:
  // One residual block per observation in idx (analytic for the plain line model).
  template <bool kIso, bool kSecond>
  void add_blocks(ceres::Problem* pb, const ObsSet& os, const std::vector<size_t>& idx,
                  ceres::LossFunction* loss) {
    for (size_t i : idx) {
      ceres::CostFunction* cf;
      if constexpr (!kIso && !kSecond)
        cf = new LineResidualAnalytic(&os.obs[i], os.lights.data());
      else if constexpr (kIso && !kSecond)
        cf = new LineIsotropicAnalytic(&os, i);
      else
        cf = LineResidual<kIso, kSecond>::Create(&os.obs[i], os.lights.data());
      pb->AddResidualBlock(cf, loss, core.kd, core.ks, &core.logn, &core.psi,
                           kIso ? iso_block_ : dummy_iso_, kSecond ? sec_ : dummy_sec_);
    }
  }

  const bool iso_, second_, chunked_, hold_psi_;
  const double held_psi_;  // radians
  bool iso_n_free_ = true, sec_angle_free_ = true;
  // isotropic k_d (3), k_s (3), log n_iso; second fiber psi_2, w. Dummies are held constant.
  double iso_block_[7] = {0.01, 0.01, 0.01, 0.01, 0.01, 0.01, std::log(20.0)};
  double sec_[2] = {M_PI / 2, 0.5};
  double dummy_iso_[1] = {0}, dummy_sec_[1] = {0};
};

}  // namespace

ceres::CostFunction* line_pixel_cost(const Observation* o, const ObsLight* lights) {
  return new LineResidualAnalytic(o, lights);
}

std::unique_ptr<ModelFit> make_line_fit(const FitOptions& opt) {
  return std::make_unique<LineFit>(opt);
}

}  // namespace aniso::fitting
