// The line-lighting model's part of a fit (MODELS.md §3): the plain model with hand-written
// derivatives (one block per pixel, or chunks of 256 pixels with reweighting for the robust
// loss), and the optional isotropic and second-fiber terms with automatic derivatives.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/angles.h"
#include "fit/start.h"
#include "models/params.h"
#include "models/safe_math.h"

namespace aniso::fitting {

namespace {

// The residual of one pixel: exposure * I(params) - y, per channel (MODELS.md §2-3).
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

// The common case (no optional terms) with hand-written derivatives: the same residual as
// LineResidual<false, false>, about 4x cheaper than Jets of size 8 (tests compare the two).
// d sqrt(1 - a^2)/da uses the same chord as models/safe_math.h below kSqrtChordEps.
class LineResidualAnalytic : public ceres::SizedCostFunction<3, 3, 3, 1, 1, 1, 1> {
 public:
  LineResidualAnalytic(const Observation* o, const ObsLight* l) : obs_(o), lights_(l) {}

  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const double* kd = p[0];
    const double* ks = p[1];
    const double logn = p[2][0], psi = p[3][0];
    const double n = std::exp(logn), c = std::cos(psi), sn = std::sin(psi);
    const LocalDir& V = obs_->V;
    const double b = clamp_unit(c * V.u + sn * V.w), db = -sn * V.u + c * V.w;
    double sV, dsV;
    sin_and_derivative(b, &sV, &dsV);
    double f[3] = {obs_->base[0], obs_->base[1], obs_->base[2]};
    double dkd[3] = {0, 0, 0}, dks[3] = {0, 0, 0}, dlogn[3] = {0, 0, 0}, dpsi[3] = {0, 0, 0};
    for (uint32_t i = 0; i < obs_->num_lights; ++i) {
      const ObsLight& l = lights_[obs_->first_light + i];
      const double nl = l.L.n;
      const double a = clamp_unit(c * l.L.u + sn * l.L.w), da = -sn * l.L.u + c * l.L.w;
      double sL, dsL;
      sin_and_derivative(a, &sL, &dsL);
      const double x = sL * sV - a * b;
      double S = 0, dS_dx = 0, dS_dlogn = 0;
      if (x > 0) {
        S = std::exp(n * std::log(x));
        dS_dx = n * S / x;
        dS_dlogn = S * n * std::log(x);
      }
      const double dx_dpsi = (dsL * sV - b) * da + (sL * dsV - a) * db;
      const double dD_dpsi = dsL * da;
      for (int k = 0; k < 3; ++k) {
        const double w = l.E[k] * nl;
        f[k] += w * (kd[k] * sL + ks[k] * S);
        dkd[k] += w * sL;
        dks[k] += w * S;
        dlogn[k] += w * ks[k] * dS_dlogn;
        dpsi[k] += w * (kd[k] * dD_dpsi + ks[k] * dS_dx * dx_dpsi);
      }
    }
    for (int k = 0; k < 3; ++k) r[k] = f[k] - obs_->y[k];
    if (!J) return true;
    if (J[0]) std::fill(J[0], J[0] + 9, 0.0);
    if (J[1]) std::fill(J[1], J[1] + 9, 0.0);
    for (int k = 0; k < 3; ++k) {
      if (J[0]) J[0][k * 3 + k] = dkd[k];
      if (J[1]) J[1][k * 3 + k] = dks[k];
      if (J[2]) J[2][k] = dlogn[k];
      if (J[3]) J[3][k] = dpsi[k];
      if (J[4]) J[4][k] = 0;
      if (J[5]) J[5][k] = 0;
    }
    return true;
  }

 private:
  // sqrt(1 - a^2) and its derivative, with the chord of models/safe_math.h near |a| = 1.
  static void sin_and_derivative(double a, double* s, double* ds) {
    const double x = 1 - a * a;
    if (x <= 0) {
      *s = 0;
      *ds = 0;
    } else if (x < kSqrtChordEps) {
      *s = x / std::sqrt(kSqrtChordEps);
      *ds = -2 * a / std::sqrt(kSqrtChordEps);
    } else {
      *s = std::sqrt(x);
      *ds = -a / *s;
    }
  }
  const Observation* obs_;
  const ObsLight* lights_;
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
      : iso_(opt.fit_isotropic), second_(opt.fit_second), chunked_(opt.chunked) {}

  Model model() const override { return Model::kLine; }
  size_t parameters() const override { return 8 + (iso_ ? 7 : 0) + (second_ ? 2 : 0); }

  std::string start(const ObsSet& os, bool progress) override {
    std::string s = line_grid_start(os, &core, progress);
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
    return true;
  }

  void residual(const ObsSet& os, size_t i, double r[3]) const override {
    const LineResidualAnalytic one(&os.obs[i], os.lights.data());
    const double dummy = 0;
    const double* params[6] = {core.kd, core.ks, &core.logn, &core.psi, &dummy, &dummy};
    one.Evaluate(params, r, nullptr);
  }

  // An isotropic lobe of zero weight leaves n_iso free, a second fiber of zero weight (w -> 1)
  // leaves its angle free: hold the free coordinate (a subset manifold), name it, and keep
  // everyone else's sigma.
  void hold_undetermined(ceres::Problem* pb, double kd_max, FitResult* res) override {
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
      else
        cf = LineResidual<kIso, kSecond>::Create(&os.obs[i], os.lights.data());
      pb->AddResidualBlock(cf, loss, core.kd, core.ks, &core.logn, &core.psi,
                           kIso ? iso_block_ : dummy_iso_, kSecond ? sec_ : dummy_sec_);
    }
  }

  const bool iso_, second_, chunked_;
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
