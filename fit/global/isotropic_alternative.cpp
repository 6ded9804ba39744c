// The isotropic alternative (fit/global/isotropic_alternative.h): the line model's isotropic part
// alone, fitted by a grid over n_iso and Ceres, and compared with the fitted material by BIC.
#include "fit/global/isotropic_alternative.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/angles.h"
#include "fit/global/solve.h"
#include "fit/solvers/fused_lm.h"
#include "fit/solvers/isotropic_pixel.h"
#include "fit/solvers/model_fit.h"
#include "models/evaluate.h"
#include "models/params.h"

namespace aniso::fitting {

namespace {

constexpr int kParams = kIsotropicParams;

// One observation's residual, per channel: E (k_d,iso <N,L>^+ + k_s,iso (<N,H>^+)^n) - y summed
// over its lights, with hand-written derivatives (k_d,iso 3, k_s,iso 3, log n_iso 1).
class IsotropicPixel : public ceres::SizedCostFunction<3, 3, 3, 1> {
 public:
  IsotropicPixel(const ObsSet* os, size_t i) : os_(os), i_(i) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const double n = std::exp(p[2][0]);
    double bd[3], bs[3], dbs[3];
    isotropic_residual(*os_, i_, p[0], p[1], n, r, bd, bs, dbs);
    if (!J) return true;
    for (int c = 0; c < 3; ++c) {
      for (int q = 0; q < 3; ++q) {
        if (J[0]) J[0][c * 3 + q] = q == c ? bd[c] : 0.0;
        if (J[1]) J[1][c * 3 + q] = q == c ? bs[c] : 0.0;
      }
      if (J[2]) J[2][c] = p[1][c] * dbs[c] * n;
    }
    return true;
  }

 private:
  const ObsSet* os_;
  size_t i_;
};

// The line model with its isotropic part (docs/models.md §3): the model both others are a part
// of, fitted only where the isotropic part alone beats the fitted material, to tell "no
// anisotropic lobe" from "a lobe the fitted model draws worse than Blinn-Phong does"
// (fit/solvers/isotropic_pixel.h). Blocks: k_d 3, k_s 3, log n 1, psi 1, isotropic 7.
class LineWithIsotropic : public ceres::SizedCostFunction<3, 3, 3, 1, 1, kIsotropicParams> {
 public:
  LineWithIsotropic(const ObsSet* os, size_t i) : os_(os), i_(i) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    line_isotropic_pixel(*os_, i_, p[0], p[1], p[2][0], p[3][0], p[4], r, J);
    return true;
  }

 private:
  const ObsSet* os_;
  size_t i_;
};

// rho(|r|^2) of one observation's residual under `loss` (null: the plain square), and the weight
// rho' iteratively reweighted least squares gives it.
double robust(const ceres::LossFunction* loss, const double r[3], double* weight = nullptr) {
  const double s = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  double rho[3] = {s, 1, 0};
  if (loss) loss->Evaluate(s, rho);
  if (weight) *weight = rho[1];
  return rho[0];
}

// A model's residuals over obs[0], obs[stride], ...: the sum of rho(|r|^2) under a loss, and of
// |r|^2.
struct Sums {
  double cost = 0, rss = 0;
  void add(const ceres::LossFunction* loss, const double r[3]) {
    cost += robust(loss, r);
    rss += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  }
};

// The isotropic part's sums (f's numbers) over every stride-th observation.
Sums isotropic_sums(const ObsSet& os, size_t stride, const IsotropicFit& f,
                    const ceres::LossFunction* loss) {
  Sums s;
  for (size_t i = 0; i < os.obs.size(); i += stride) {
    double r[3], bd[3], bs[3], dbs[3];
    isotropic_residual(os, i, f.kd, f.ks, f.n, r, bd, bs, dbs);
    s.add(loss, r);
  }
  return s;
}

// min over a, b >= 0 of sum (a d + b s - y)^2, from the sums of products.
void two_nonneg(double dd, double ds, double ss, double dy, double sy, double yy, double* a,
                double* b, double* rss) {
  auto cost = [&](double x, double z) {
    return yy - 2 * (x * dy + z * sy) + x * x * dd + 2 * x * z * ds + z * z * ss;
  };
  double best_a = 0, best_b = 0, best = yy;
  auto consider = [&](double x, double z) {
    const double c = cost(x, z);
    if (x >= 0 && z >= 0 && c < best) best = c, best_a = x, best_b = z;
  };
  const double det = dd * ss - ds * ds;
  if (det > 1e-12 * std::max(dd * ss, 1e-300))
    consider((dy * ss - sy * ds) / det, (sy * dd - dy * ds) / det);
  if (dd > 0) consider(std::max(0.0, dy / dd), 0);
  if (ss > 0) consider(0, std::max(0.0, sy / ss));
  *a = best_a, *b = best_b, *rss = std::max(0.0, best);
}

// The grid over n_iso: k_d,iso and k_s,iso are linear in the model, so each node's best pair per
// channel is closed form and the node of least sum of squares is the start.
IsotropicFit grid_start(const ObsSet& os, size_t stride) {
  constexpr int kNodes = 33;  // n_iso from 1 to 1e4, 4 nodes a decade
  IsotropicFit best;
  best.cost = HUGE_VAL;
  for (int t = 0; t < kNodes; ++t) {
    const double n = std::pow(1e4, t / double(kNodes - 1));
    double s[3][6] = {};  // per channel: dd, ds, ss, dy, sy, yy
    for (size_t i = 0; i < os.obs.size(); i += stride) {
      double bd[3], bs[3], dbs[3];
      isotropic_basis(os, i, n, bd, bs, dbs);
      for (int c = 0; c < 3; ++c) {
        const double y = os.obs[i].y[c];
        s[c][0] += bd[c] * bd[c], s[c][1] += bd[c] * bs[c], s[c][2] += bs[c] * bs[c];
        s[c][3] += bd[c] * y, s[c][4] += bs[c] * y, s[c][5] += y * y;
      }
    }
    IsotropicFit f;
    f.n = n;
    for (int c = 0; c < 3; ++c) {
      double r;
      two_nonneg(s[c][0], s[c][1], s[c][2], s[c][3], s[c][4], s[c][5], &f.kd[c], &f.ks[c], &r);
      f.cost += r;
    }
    if (f.cost < best.cost) best = f;
  }
  return best;
}

// sigma from J^T W J over the observations fitted, times the residual variance (W: the robust
// loss's weights, 1 without one); n_iso is left out where k_s,iso is about 0 (no lobe to measure
// it from).
void residual_scaled_sigmas(const ObsSet& os, size_t stride, const ceres::LossFunction* loss,
                            IsotropicFit* f) {
  const double kd_max = std::max({f->kd[0], f->kd[1], f->kd[2]});
  const double ks_max = std::max({f->ks[0], f->ks[1], f->ks[2]});
  f->n_determined = ks_max > kKsNegligible * std::max(1.0, kd_max);
  const int k = f->n_determined ? kParams : kParams - 1;
  // Fixed sizes: no heap, and no instance of Eigen's dynamic decompositions beside the ones
  // libceres holds (built without the sanitizers, they free what another instance allocates).
  using Mat = Eigen::Matrix<double, kParams, kParams>;
  using Vec = Eigen::Matrix<double, kParams, 1>;
  Mat info = Mat::Zero();
  double wrss = 0, values = 0;
  for (size_t i = 0; i < os.obs.size(); i += stride) {
    double bd[3], bs[3], dbs[3], r[3], w = 1;
    isotropic_residual(os, i, f->kd, f->ks, f->n, r, bd, bs, dbs);
    robust(loss, r, &w);
    for (int c = 0; c < 3; ++c) {
      Vec g = Vec::Zero();
      g[c] = bd[c];
      g[3 + c] = bs[c];
      if (f->n_determined) g[6] = f->ks[c] * dbs[c] * f->n;
      info.noalias() += w * g * g.transpose();
      wrss += w * r[c] * r[c];
      values += 1;
    }
  }
  const double dof = std::max(1.0, values - k);
  if (!f->n_determined) info(6, 6) = 1;  // n_iso held: its row and column out of the inverse
  // The pseudo-inverse over the eigenvalues above 1e-12 of the largest (a channel the data leave
  // at a bound gives none).
  const Eigen::SelfAdjointEigenSolver<Mat> es(info);
  const Vec ev = es.eigenvalues();
  Vec inv = Vec::Zero();
  for (int q = 0; q < kParams; ++q)
    if (ev[q] > 1e-12 * ev.maxCoeff()) inv[q] = 1 / ev[q];
  const Mat cov =
      es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose() * (wrss / dof);
  for (int c = 0; c < 3; ++c) {
    f->sigma_kd[c] = std::sqrt(std::max(0.0, cov(c, c)));
    f->sigma_ks[c] = std::sqrt(std::max(0.0, cov(3 + c, 3 + c)));
  }
  f->sigma_n = f->n_determined ? f->n * std::sqrt(std::max(0.0, cov(6, 6))) : 0;
}

std::string fmt(const char* f, double a, double b, double c, double d) {
  char buf[200];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

// The global fit's options without its terminal lines; for the comparison alone, to a cost within
// 1e-9 of itself (that moves a BIC over 10^5 values by 1e-4, far below any difference that
// decides); a material written, to the global fit's own tolerances.
ceres::Solver::Options quiet_solver_options(const FitOptions& opt, bool written) {
  ceres::Solver::Options so = solver_options(opt);
  so.callbacks.clear();
  if (written) return so;
  so.max_num_iterations = 100;
  so.function_tolerance = 1e-9;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-9;
  return so;
}

// Sum of rho of the line model with its isotropic part on obs[0], obs[stride], ..., started from
// the fitted material's line numbers and the isotropic part's fit.

Sums fit_line_with_isotropic(const ObsSet& os, size_t stride, const FitOptions& opt,
                             double loss_scale, const Material& fitted, const IsotropicFit& iso) {
  Core c;
  for (int k = 0; k < 3; ++k) c.kd[k] = fitted.kd[k], c.ks[k] = fitted.ks[k];
  c.logn = std::log(fitted.n);
  c.psi = deg_to_rad(fitted.fiber_angle_deg);
  double b[kParams] = {iso.kd[0], iso.kd[1], iso.kd[2],      iso.ks[0],
                       iso.ks[1], iso.ks[2], std::log(iso.n)};
  const std::unique_ptr<ceres::LossFunction> loss(make_loss(opt.loss, loss_scale));
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem pb(po);
  for (size_t i = 0; i < os.obs.size(); i += stride)
    pb.AddResidualBlock(new LineWithIsotropic(&os, i), loss.get(), c.kd, c.ks, &c.logn, &c.psi, b);
  set_core_bounds(&pb, &c);
  for (int k = 0; k < 3; ++k) {
    set_param_bounds(&pb, b, k, "isotropic.kd");
    set_param_bounds(&pb, b, 3 + k, "isotropic.ks");
  }
  set_param_bounds(&pb, b, 6, "isotropic.n");
  ceres::Solver::Summary sum;
  ceres::Solve(quiet_solver_options(opt, false), &pb, &sum);
  Sums out;
  const double* params[5] = {c.kd, c.ks, &c.logn, &c.psi, b};
  for (size_t i = 0; i < os.obs.size(); i += stride) {
    double r[3];
    LineWithIsotropic(&os, i).Evaluate(params, r, nullptr);
    out.add(loss.get(), r);
  }
  return out;
}

// The isotropic part by the fused solver (fit/solvers/fused_lm.h, P = 7: k_d,iso and k_s,iso per
// channel, log n_iso shared) from `f`: one pass over obs[0], obs[stride], ... a step, where Ceres'
// residual block a pixel costs several times the model itself. Its minimum is Ceres' with the
// same loss (the loss by its weights, as the global fit's fused solve):
// FitSolvers.TheIsotropicPartFusedAsCeres.
void fused_isotropic_part(const ObsSet& os, size_t stride, const FitOptions& opt, double loss_scale,
                          IsotropicFit* f) {
  const size_t count = (os.obs.size() + stride - 1) / stride;
  const RobustLoss loss{opt.loss, loss_scale};
  tbb::task_arena arena(std::max(1, opt.threads));
  auto pass = [&](const VecP<kParams>& x, bool jac) {
    const double kd[3] = {x(0), x(1), x(2)}, ks[3] = {x(3), x(4), x(5)}, n = std::exp(x(6));
    return fused_pass<kParams>(count, loss, jac, &arena, [&](size_t j, ObsRow<kParams>* d) {
      double bd[3], bs[3], dbs[3];
      isotropic_residual(os, j * stride, kd, ks, n, d->r, bd, bs, dbs);
      for (int c = 0; c < 3; ++c) {
        d->dkd[c] = bd[c];
        d->dks[c] = bs[c];
        d->shared[c][0] = ks[c] * dbs[c] * n;
      }
    });
  };
  VecP<kParams> lo, hi, x;
  for (int c = 0; c < 3; ++c) {
    const ParamSpec &kd = line_param("isotropic.kd"), &ks = line_param("isotropic.ks");
    lo(c) = kd.lo, hi(c) = kd.hi, x(c) = f->kd[c];
    lo(3 + c) = ks.lo, hi(3 + c) = ks.hi, x(3 + c) = f->ks[c];
  }
  const ParamSpec& n = line_param("isotropic.n");
  lo(6) = std::log(n.lo), hi(6) = std::log(n.hi), x(6) = std::log(f->n);
  FusedSums<kParams> cur;
  FusedSolve out;
  fused_lm<kParams>(pass, lo, hi, 3.0 * double(count), opt.max_iterations, &x, &cur, &out);
  for (int c = 0; c < 3; ++c) f->kd[c] = x(c), f->ks[c] = x(3 + c);
  f->n = std::exp(x(6));
  f->cost = cur.cost;
  f->converged = out.converged;
}

}  // namespace

IsotropicFit fit_isotropic_part(const ObsSet& os, size_t stride, const FitOptions& opt,
                                double loss_scale, const IsotropicFit* from, bool sigmas) {
  IsotropicFit f = from ? *from : grid_start(os, stride);
  if (!sigmas && !opt.ceres_solver) {  // the comparison alone: the fused solver
    fused_isotropic_part(os, stride, opt, loss_scale, &f);
    f.rss = isotropic_sums(os, stride, f, nullptr).rss;
    return f;
  }
  double logn = std::log(f.n);
  const std::unique_ptr<ceres::LossFunction> loss(make_loss(opt.loss, loss_scale));
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem pb(po);
  for (size_t i = 0; i < os.obs.size(); i += stride)
    pb.AddResidualBlock(new IsotropicPixel(&os, i), loss.get(), f.kd, f.ks, &logn);
  for (int c = 0; c < 3; ++c) {
    set_param_bounds(&pb, f.kd, c, "isotropic.kd");
    set_param_bounds(&pb, f.ks, c, "isotropic.ks");
  }
  set_param_bounds(&pb, &logn, 0, "isotropic.n");
  ceres::Solver::Summary sum;
  ceres::Solve(quiet_solver_options(opt, sigmas), &pb, &sum);
  f.n = std::exp(logn);
  f.cost = 2 * sum.final_cost;  // Ceres' cost is half the sum of rho
  f.converged = sum.termination_type == ceres::CONVERGENCE;
  f.rss = isotropic_sums(os, stride, f, nullptr).rss;
  if (sigmas) residual_scaled_sigmas(os, stride, loss.get(), &f);
  return f;
}

void test_isotropic_alternative(const ObsSet& os, const FitOptions& opt, FitResult* res) {
  if (!opt.test_isotropic || opt.maps_w > 0 || opt.global || os.topology != TopologyMode::kGlobalS)
    return;
  const size_t count = os.obs.size();
  const double per = os.grey ? 1.0 : 3.0;  // values an observation holds (summarize's m)
  if (double(count) * per <= kParams + 1) return;
  const size_t stride =
      std::max<size_t>(1, (count + kIsotropicTestObservations - 1) / kIsotropicTestObservations);
  FitReport& rep = res->report;
  const IsotropicFit iso = fit_isotropic_part(os, stride, opt, rep.loss_scale);

  // The fitted material's sum of rho on the same observations, under the fit's own loss.
  const std::unique_ptr<ceres::LossFunction> loss(make_loss(opt.loss, rep.loss_scale));
  const Evaluator ev(res->material);
  Sums fitted;
  double signal = 0;  // sum of |y|^2
  size_t used = 0;
  for (size_t i = 0; i < count; i += stride, ++used) {
    const Observation& o = os.obs[i];
    double r[3];
    pixel_residual(
        &o, os.lights.data(), [&](const LocalDir& L, const LocalDir& V, double* f) { ev(L, V, f); },
        r);
    fitted.add(loss.get(), r);
    for (int c = 0; c < 3; ++c) signal += double(o.y[c]) * o.y[c];
  }
  const double m = double(used) * per;
  auto bic = [&](double s, double k) {
    return m * std::log(std::max(s / (os.grey ? 3.0 : 1.0), 1e-300) / m) + k * std::log(m);
  };
  FitReport::AnisotropyTest& t = rep.anisotropy;
  t.tested = true;
  t.values = static_cast<size_t>(m);
  t.bic_anisotropic = bic(fitted.cost, double(rep.parameters));
  t.bic_isotropic = bic(iso.cost, kParams);
  // A lobe is shown where a model with one has the lower BIC and draws at least kLobeShare of
  // the signal's energy the isotropic part leaves: on noise-free data BIC alone takes any
  // systematic difference (a grid's interpolation) for a lobe.
  auto shown = [&](double b, const Sums& x) {
    t.lobe_share = std::max(t.lobe_share, (iso.rss - x.rss) / std::max(signal, 1e-300));
    return b < t.bic_isotropic && iso.rss - x.rss > kLobeShare * signal;
  };
  t.isotropic_preferred = !shown(t.bic_anisotropic, fitted);
  // A line fit with its isotropic part is already the model that holds both. It also holds the
  // isotropic part alone (k_d = k_s = 0): where it fits worse than that part, its solver stopped in
  // a worse minimum, which says nothing of whether the data have a lobe.
  const bool fitted_holds_both = opt.fit_isotropic && res->material.model == Model::kLine;
  const bool worse_minimum = fitted_holds_both && fitted.cost > iso.cost;
  if (t.isotropic_preferred && !fitted_holds_both) {
    // Is there an anisotropic lobe the fitted model draws worse than Blinn-Phong (a GGX lobe, a
    // lobe of two parts)? The model that holds both answers it.
    const Sums both = fit_line_with_isotropic(os, stride, opt, rep.loss_scale, res->material, iso);
    t.with_both_tested = true;
    t.bic_with_both = bic(both.cost, 8 + kParams);
    t.isotropic_preferred = !shown(t.bic_with_both, both);
  }
  for (int c = 0; c < 3; ++c) t.iso_kd[c] = iso.kd[c], t.iso_ks[c] = iso.ks[c];
  t.iso_n = iso.n;
  const std::string model = model_name(res->material.model);
  const std::string subset =
      stride > 1 ? " (one observation in " + std::to_string(stride) + ")" : "";
  const std::string comparison =
      fmt("BIC %.1f for the isotropic part alone (7 numbers) against %.1f for the fitted ",
          t.bic_isotropic, t.bic_anisotropic, 0, 0) +
      model + " model (" + std::to_string(rep.parameters) + " numbers) over " +
      std::to_string(t.values) + " values" + subset +
      fmt("; the best lobe draws %.2g of the signal's energy beyond the isotropic part (a lobe "
          "counts from %.0e)",
          t.lobe_share, kLobeShare, 0, 0);
  if (!t.isotropic_preferred && t.with_both_tested) {
    rep.warnings.push_back(
        "the isotropic part alone (Lambert + Blinn-Phong) fits the data better than the fitted " +
        model + " model (" + comparison +
        fmt("), but the line model with both lobes fits them "
            "better still (BIC %.1f): the data have an "
            "anisotropic lobe the fitted model draws poorly; "
            "--fit-isotropic fits both",
            t.bic_with_both, 0, 0, 0));
    return;
  }
  if (!t.isotropic_preferred) {
    if (t.bic_isotropic - t.bic_anisotropic < kBicStrong)
      rep.warnings.push_back("the anisotropic lobe is weakly supported: " + comparison +
                             ", lower by less than " + fmt("%.0f", kBicStrong, 0, 0, 0) +
                             ": the fiber direction may describe noise, not the material");
    return;
  }
  if (opt.keep_anisotropic) {
    res->sigma.erase("fiber_angle_deg");
    res->sigma_noise_only.erase("fiber_angle_deg");
    res->undetermined["fiber_angle_deg"] =
        "the data show no anisotropic lobe: " + comparison +
        " (kept by --keep-anisotropic): the fiber direction describes no anisotropy of the "
        "material";
    rep.warnings.push_back(
        {"fiber_angle_deg: " + res->undetermined["fiber_angle_deg"], WarningAbout::kFiberAngle});
    return;
  }

  // The isotropic material, fitted again on more of the observations, with its sigma.
  const size_t every = std::max<size_t>(
      1, (count + kIsotropicWrittenObservations - 1) / kIsotropicWrittenObservations);
  const IsotropicFit all = fit_isotropic_part(os, every, opt, rep.loss_scale, &iso, true);
  // Plain, over every observation: the report's RMS and BIC.
  const double rss = isotropic_sums(os, 1, all, nullptr).rss;
  const FitReport before = rep;
  Material mat;
  mat.model = Model::kLine;
  mat.ka = res->material.ka;
  mat.base_dir = res->material.base_dir;
  mat.kd = {0, 0, 0};
  mat.ks = {0, 0, 0};
  mat.has_isotropic = true;
  for (int c = 0; c < 3; ++c) mat.iso_kd[c] = all.kd[c], mat.iso_ks[c] = all.ks[c];
  mat.iso_n = all.n;
  res->material = mat;
  t.isotropic_written = true;

  res->sigma.clear();
  res->sigma["isotropic.kd"] = {all.sigma_kd[0], all.sigma_kd[1], all.sigma_kd[2]};
  res->sigma["isotropic.ks"] = {all.sigma_ks[0], all.sigma_ks[1], all.sigma_ks[2]};
  if (all.n_determined) res->sigma["isotropic.n"] = {all.sigma_n};
  res->sigma_noise_only = res->sigma;
  res->uncertainty_basis = "the isotropic model's: J^T W J over the observations it was fitted to" +
                           (every > 1 ? " (one in " + std::to_string(every) + ")" : std::string()) +
                           " times the residual variance";
  res->correlation_names.clear();
  res->correlation.clear();
  const std::string why =
      worse_minimum
          ? "the fitted line model with its isotropic part fits worse than that part alone (" +
                comparison +
                "): it holds that part, so its solver stopped in a worse minimum and whether the "
                "data have a lobe is not shown; the material is the isotropic part alone"
          : "the data show no anisotropic lobe (" + comparison +
                "): the material is the isotropic part alone";
  res->undetermined.clear();
  res->undetermined["fiber_angle_deg"] = why;
  res->undetermined["n"] = why;
  if (!all.n_determined)
    res->undetermined["isotropic.n"] =
        "the isotropic specular k_s,iso is about 0: no lobe to measure n_iso from";
  res->fixed.erase("isotropic");
  res->fixed.erase("second_fiber");
  res->fixed["kd"] = res->fixed["ks"] = "0: " + why;

  const double all_values = double(count) * per;
  rep.parameters = kParams;
  rep.rss = rss / (os.grey ? 3.0 : 1.0);
  rep.rms = std::sqrt(rss / (3.0 * double(count)));
  rep.bic = all_values * std::log(std::max(rep.rss, 1e-300) / all_values) +
            kParams * std::log(all_values);
  rep.covariance = "isotropic model: residual-scaled";
  // The fitted model's misfit, fiber-direction and solver warnings were about a material not
  // written.
  std::vector<Warning> kept;
  for (const auto& w : rep.warnings)
    if (w.about != WarningAbout::kGlobalMisfit && w.about != WarningAbout::kFiberAngle &&
        w.about != WarningAbout::kSolverStopped)
      kept.push_back(w);
  rep.warnings = std::move(kept);
  rep.warnings.push_back(
      (worse_minimum ? "the fit with --fit-isotropic stopped in a worse minimum than its own "
                       "isotropic part: " +
                           comparison +
                           ". The material written is that part alone (Lambert + Blinn-Phong) "
                           "with k_d = k_s = 0 and no fiber direction; fit without "
                           "--fit-isotropic for the line model's lobe, or --keep-anisotropic "
                           "writes the " +
                           model + " fit as it stopped"
                     : "the data show no anisotropic lobe: " + comparison +
                           ". The material written is the isotropic part alone (Lambert + "
                           "Blinn-Phong) with k_d = k_s = 0 and no fiber direction; "
                           "--keep-anisotropic writes the " +
                           model + " fit instead"));
  if (!all.converged)
    rep.warnings.push_back(
        "the isotropic material's solve stopped before converging: its numbers may not be the "
        "minimum");
  if (auto w = misfit_warning(os, rep); !w.empty())
    rep.warnings.push_back({w, WarningAbout::kGlobalMisfit});
  rep.model_selection = (rep.model_selection.empty() ? "" : rep.model_selection + "; then ") +
                        "isotropic part alone: " + comparison;
}

}  // namespace aniso::fitting
