// Uncertainty of a solution (docs/models.md §6): coordinates the data leave free are held and
// named, the covariance of the rest comes from Ceres (rank deficiency fails rather than giving a
// zero variance), scaled by the residual variance; sigmas that say nothing become "undetermined".
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "core/angles.h"
#include "fit/global/solve.h"
#include "fit/global/view_sandwich.h"

namespace aniso::fitting {

namespace {

// The covariance of the fitted blocks in their ambient coordinates (Ceres' convention), from one
// of two sources below.
class CovarianceSource {
 public:
  virtual ~CovarianceSource() = default;
  virtual bool block(const double* a, const double* b, double* out) const = 0;
  virtual bool matrix(const std::vector<const double*>& blocks, double* out) const = 0;
};

ceres::Covariance::Options ceres_covariance_options(int threads) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = 0;  // rank deficiency must fail, never produce a zero variance
  co.min_reciprocal_condition_number = 1e-14;
  co.num_threads = std::max(1, threads);
  return co;
}

// Ceres' own (dense SVD of the whole Jacobian): the reference, and the path for N^2 texel maps.
class CeresCovariance : public CovarianceSource {
 public:
  explicit CeresCovariance(int threads) : cov_(ceres_covariance_options(threads)) {}
  bool compute(ceres::Problem* pb, const std::vector<Block>& blocks, bool all_pairs) {
    if (all_pairs) {
      std::vector<const double*> list;
      for (const Block& b : blocks) list.push_back(b.values);
      return cov_.Compute(list, pb);
    }
    std::vector<std::pair<const double*, const double*>> pairs;
    for (const Block& b : blocks) pairs.push_back({b.values, b.values});
    return cov_.Compute(pairs, pb);
  }
  bool block(const double* a, const double* b, double* out) const override {
    return cov_.GetCovarianceBlock(a, b, out);
  }
  bool matrix(const std::vector<const double*>& blocks, double* out) const override {
    return cov_.GetCovarianceMatrix(blocks, out);
  }

 private:
  ceres::Covariance cov_;
};

// From the normal equations: J^T J accumulated block by block in one pass over the residuals
// (robust loss and manifolds applied, as Ceres does), never the Jacobian itself; the rank test on
// the eigenvalues of the column-scaled J^T J. For problems of a few dozen parameters (every fit
// without a texel map): O(P^2) memory instead of Ceres' dense Jacobian and SVD.
class NormalEquations : public CovarianceSource {
 public:
  static constexpr int kMaxParameters = 64;
  // False when the problem is not one this path covers (a free block outside `blocks`, too many
  // parameters) or the information matrix is rank deficient (`*deficient` tells which).
  bool compute(ceres::Problem* pb, const std::vector<Block>& blocks, bool* deficient);
  // The same from J^T J already summed by the solver (`info` over `order`, whose blocks are
  // contiguous in it): the fused solve's, with pb holding only the parameter blocks.
  bool compute_given(ceres::Problem* pb, const std::vector<Block>& blocks,
                     const std::vector<double>& info, const std::vector<const double*>& order,
                     bool* deficient);
  bool block(const double* a, const double* b, double* out) const override;
  bool matrix(const std::vector<const double*>& blocks, double* out) const override;

 private:
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  struct Slot {
    int offset = 0, tangent = 0, ambient = 0;
    Eigen::MatrixXd plus;  // ambient x tangent: the manifold's Plus Jacobian (or identity)
  };
  bool index(ceres::Problem* pb, const std::vector<Block>& blocks);
  bool accumulate(ceres::Problem* pb, Eigen::MatrixXd* info) const;
  bool invert(const Eigen::MatrixXd& info, bool* deficient);
  std::map<const double*, Slot> slots_;
  int p_ = 0;
  Eigen::MatrixXd cov_;  // tangent space
};

// Where each free block sits in the tangent-space parameter vector; false if a free block of the
// problem is not among `blocks` or there are too many parameters for a dense P x P.
bool NormalEquations::index(ceres::Problem* pb, const std::vector<Block>& blocks) {
  for (const Block& b : blocks) {
    if (pb->IsParameterBlockConstant(b.values)) continue;
    Slot s;
    s.offset = p_;
    s.ambient = pb->ParameterBlockSize(b.values);
    s.tangent = pb->ParameterBlockTangentSize(b.values);
    s.plus = Eigen::MatrixXd::Identity(s.ambient, s.tangent);
    if (const ceres::Manifold* mf = pb->GetManifold(b.values)) {
      RowMajor j(s.ambient, s.tangent);
      mf->PlusJacobian(b.values, j.data());
      s.plus = j;
    }
    p_ += s.tangent;
    slots_[b.values] = s;
  }
  std::vector<double*> all;
  pb->GetParameterBlocks(&all);
  for (double* x : all)
    if (!pb->IsParameterBlockConstant(x) && !slots_.count(x)) return false;
  return p_ > 0 && p_ <= kMaxParameters;
}

// J^T J over every residual block, each block's Jacobian evaluated once and dropped.
bool NormalEquations::accumulate(ceres::Problem* pb, Eigen::MatrixXd* info) const {
  *info = Eigen::MatrixXd::Zero(p_, p_);
  std::vector<ceres::ResidualBlockId> ids;
  pb->GetResidualBlocks(&ids);
  std::vector<double> r;
  std::vector<std::vector<double>> jac;
  for (ceres::ResidualBlockId id : ids) {
    std::vector<double*> params;
    pb->GetParameterBlocksForResidualBlock(id, &params);
    const int m = pb->GetCostFunctionForResidualBlock(id)->num_residuals();
    r.resize(m);
    jac.resize(params.size());
    std::vector<double*> jp(params.size(), nullptr);
    std::vector<const Slot*> sp(params.size(), nullptr);
    for (size_t k = 0; k < params.size(); ++k) {
      const auto it = slots_.find(params[k]);
      if (it == slots_.end()) continue;
      sp[k] = &it->second;
      jac[k].resize(static_cast<size_t>(m) * it->second.tangent);
      jp[k] = jac[k].data();
    }
    double cost;
    if (!pb->EvaluateResidualBlock(id, true, &cost, r.data(), jp.data())) return false;
    for (size_t a = 0; a < params.size(); ++a)
      for (size_t b = a; b < params.size(); ++b) {
        if (!sp[a] || !sp[b]) continue;
        const Eigen::Map<const RowMajor> ja(jp[a], m, sp[a]->tangent), jb(jp[b], m, sp[b]->tangent);
        const Eigen::MatrixXd blk = ja.transpose() * jb;
        info->block(sp[a]->offset, sp[b]->offset, sp[a]->tangent, sp[b]->tangent) += blk;
        if (params[a] != params[b])
          info->block(sp[b]->offset, sp[a]->offset, sp[b]->tangent, sp[a]->tangent) +=
              blk.transpose();
      }
  }
  return true;
}

bool NormalEquations::compute(ceres::Problem* pb, const std::vector<Block>& blocks,
                              bool* deficient) {
  *deficient = false;
  Eigen::MatrixXd info;
  if (!index(pb, blocks) || !accumulate(pb, &info)) return false;
  return invert(info, deficient);
}

bool NormalEquations::compute_given(ceres::Problem* pb, const std::vector<Block>& blocks,
                                    const std::vector<double>& given,
                                    const std::vector<const double*>& order, bool* deficient) {
  *deficient = false;
  if (!index(pb, blocks)) return false;
  std::map<const double*, int> at;  // where each block starts in `given`
  int n = 0;
  for (const double* b : order) at[b] = n, n += pb->ParameterBlockSize(b);
  if (given.size() != static_cast<size_t>(n) * n) return false;
  Eigen::MatrixXd info(p_, p_);
  for (const auto& [a, sa] : slots_)
    for (const auto& [b, sb] : slots_) {
      if (!at.count(a) || !at.count(b) || sa.tangent != sa.ambient || sb.tangent != sb.ambient)
        return false;
      for (int i = 0; i < sa.tangent; ++i)
        for (int j = 0; j < sb.tangent; ++j)
          info(sa.offset + i, sb.offset + j) = given[(at[a] + i) * n + at[b] + j];
    }
  return invert(info, deficient);
}

bool NormalEquations::invert(const Eigen::MatrixXd& info, bool* deficient) {
  // Column scaling, then the rank test on the eigenvalues: a ratio below 1e-14 (a singular-value
  // ratio of 1e-7 in J) is not trusted as information.
  const Eigen::VectorXd d = info.diagonal();
  if (!d.allFinite() || !(d.minCoeff() > 0)) {
    *deficient = true;
    return false;
  }
  const Eigen::VectorXd scale = d.cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd a = scale.asDiagonal() * info * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(a);
  const Eigen::VectorXd ev = es.eigenvalues();
  constexpr double kMinEigenRatio = 1e-14;
  if (!(ev.minCoeff() > kMinEigenRatio * ev.maxCoeff())) {
    *deficient = true;
    return false;
  }
  const Eigen::MatrixXd inv =
      es.eigenvectors() * ev.cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
  cov_ = scale.asDiagonal() * inv * scale.asDiagonal();
  return true;
}

bool NormalEquations::block(const double* a, const double* b, double* out) const {
  const auto ia = slots_.find(a), ib = slots_.find(b);
  if (ia == slots_.end() || ib == slots_.end()) return false;
  const Slot &sa = ia->second, &sb = ib->second;
  Eigen::Map<RowMajor>(out, sa.ambient, sb.ambient) =
      sa.plus * cov_.block(sa.offset, sb.offset, sa.tangent, sb.tangent) * sb.plus.transpose();
  return true;
}

bool NormalEquations::matrix(const std::vector<const double*>& blocks, double* out) const {
  int n = 0;
  for (const double* b : blocks) {
    if (!slots_.count(b)) return false;
    n += slots_.at(b).ambient;
  }
  int row = 0;
  for (const double* a : blocks) {
    const int na = slots_.at(a).ambient;
    int col = 0;
    for (const double* b : blocks) {
      const int nb = slots_.at(b).ambient;
      std::vector<double> c(static_cast<size_t>(na) * nb);
      block(a, b, c.data());
      for (int i = 0; i < na; ++i)
        for (int j = 0; j < nb; ++j) out[(row + i) * n + col + j] = c[i * nb + j];
      col += nb;
    }
    row += na;
  }
  return true;
}

// k_s -> 0 leaves n undetermined: hold log n constant so the covariance of the rest stays
// meaningful, and report n as undetermined rather than confident. Returns whether n is free.
bool hold_free_exponent(ModelFit* m, ceres::Problem* pb, FitResult* res) {
  const Core& c = m->core;
  const double ks_max = std::max({c.ks[0], c.ks[1], c.ks[2]});
  const double kd_max = std::max({c.kd[0], c.kd[1], c.kd[2]});
  const bool n_free = ks_max > kKsNegligible * std::max(1.0, kd_max);
  if (!n_free) {
    res->undetermined["n"] =
        "k_s is about 0 (" + std::to_string(ks_max) + "): no specular lobe to measure n from";
    pb->SetParameterBlockConstant(&m->core.logn);
  }
  m->hold_undetermined(pb, kd_max, res);
  return n_free;
}

// The full correlation matrix of the fitted numbers (not per-texel maps), in the coordinates the
// solver uses (log n, psi in radians): how the parameters trade off. Held coordinates of subset
// manifolds are asked in the ambient space and left at 0 correlation.
void correlation(const CovarianceSource& cov, ceres::Problem* pb, const std::vector<Block>& blocks,
                 FitResult* res) {
  std::vector<const double*> cb;
  std::vector<std::string>& names = res->correlation_names;
  for (const Block& b : blocks) {
    if (b.names.empty() || pb->IsParameterBlockConstant(b.values)) continue;
    cb.push_back(b.values);
    names.insert(names.end(), b.names.begin(), b.names.end());
  }
  const size_t k = names.size();
  std::vector<double> c(k * k, 0.0);
  if (cb.empty() || !cov.matrix(cb, c.data())) {
    names.clear();
    return;
  }
  res->correlation.assign(k, std::vector<double>(k, 0.0));
  for (size_t i = 0; i < k; ++i)
    for (size_t j = 0; j < k; ++j) {
      const double d = std::sqrt(c[i * k + i] * c[j * k + j]);
      res->correlation[i][j] = d > 0 && std::isfinite(d) ? c[i * k + j] / d : (i == j);
    }
}

// sigma of the core numbers; psi or n this uncertain says nothing.
// A psi held constant (FitOptions::hold_psi_deg) has its sigma from the caller.
void core_sigmas(const SigmaOf& sigma, Core* c, bool n_free, bool psi_free, FitResult* res) {
  res->sigma["kd"] = sigma(c->kd, 3);
  res->sigma["ks"] = sigma(c->ks, 3);
  if (psi_free) {
    const double spsi = rad_to_deg(sigma(&c->psi, 1)[0]);
    // A lone light along T (s_L -> 0), or no lobe.
    constexpr double kPsiUndeterminedDeg = 10.0;
    if (spsi > kPsiUndeterminedDeg)
      res->undetermined["fiber_angle_deg"] =
          "sigma " + std::to_string(spsi) + " deg: the data barely constrain psi";
    else
      res->sigma["fiber_angle_deg"] = {spsi};
  }
  if (!n_free) return;
  const double sl = sigma(&c->logn, 1)[0];
  constexpr double kLogNUndetermined = 1.0;  // a factor e either way: n is not known
  if (sl > kLogNUndetermined)
    res->undetermined["n"] =
        "sigma of log n is " + std::to_string(sl) + ": the lobe is barely measured";
  else
    res->sigma["n"] = {std::exp(c->logn) * sl};
}

// A variance that is not a finite number (0 * inf on data without signal) is no uncertainty:
// the parameter is reported as undetermined instead.
void drop_nonfinite_sigmas(FitResult* res) {
  for (auto it = res->sigma.begin(); it != res->sigma.end();) {
    bool ok = true;
    for (double v : it->second) ok &= std::isfinite(v);
    if (ok) {
      ++it;
      continue;
    }
    res->undetermined[it->first] =
        "its variance is not finite: the data carry no information about it";
    it = res->sigma.erase(it);
  }
}

// The whole uncertainty (fit/global/view_sandwich.h): where the capture came from a photo shoot, or
// the residual is well above the images' noise, each sigma is the larger of the noise's and the
// spread the views' own residuals show.
void whole_uncertainty(ModelFit* m, const ObsSet& os, const FitOptions& opt, const Solution& sol,
                       const CovarianceSource& cov, ceres::Problem* pb,
                       const std::vector<Block>& blocks, double s2, bool n_free, bool psi_free,
                       FitResult* res) {
  const bool misfit = sol.misfit;
  if (os.view_lights.empty() || (!os.from_shoot && !misfit)) return;
  std::vector<std::pair<double*, int>> free;
  std::vector<const double*> list;
  for (const Block& b : blocks)
    if (!pb->IsParameterBlockConstant(b.values) &&
        pb->ParameterBlockTangentSize(b.values) == b.size)
      free.push_back({b.values, b.size}), list.push_back(b.values);
  size_t P = 0;
  for (const auto& f : free) P += static_cast<size_t>(f.second);
  std::vector<double> ainv(P * P);
  if (P == 0 || !cov.matrix(list, ainv.data())) return;
  size_t views = 0;
  const std::vector<double> c = per_view_covariance(m, os, free, ainv, opt.threads, &views);
  if (c.empty()) {
    const std::string why = "the views' spread needs " + std::to_string(P + 2) +
                            " views with pixels for " + std::to_string(P) +
                            " fitted numbers (this set has " +
                            std::to_string(os.view_lights.size()) + ") and at most 2^25 pixels";
    res->uncertainty_basis += "; not the whole uncertainty: " + why;
    // Said where a person reads it: the noise's sigma of a shoot or a misfit is often tens of
    // times too small (docs/photo-shoot.md, "The uncertainty of a fit of an imported capture").
    res->report.warnings.push_back(
        "the uncertainty is the images' noise alone, not the whole (" + why +
        "): the shoot's errors and the model's misfit are not in it, and it may be many times "
        "too small. Fit fewer numbers (without --fit-isotropic or --fit-second-fiber) or "
        "import more photos");
    return;
  }
  std::map<const double*, size_t> at;
  size_t k = 0;
  for (const auto& f : free) at[f.first] = k, k += static_cast<size_t>(f.second);
  const SigmaOf whole = [&](const double* b, int size) {
    std::vector<double> cv(static_cast<size_t>(size) * size);
    cov.block(b, b, cv.data());
    std::vector<double> d(size);
    const auto it = at.find(b);
    for (int i = 0; i < size; ++i) {
      double v = std::max(cv[i * size + i], 0.0) * s2;
      if (it != at.end()) v = std::max(v, c[(it->second + i) * P + it->second + i]);
      d[i] = std::sqrt(v);
    }
    return d;
  };
  res->sigma.clear();
  core_sigmas(whole, &m->core, n_free, psi_free, res);
  m->sigmas(whole, pb, res);
  drop_nonfinite_sigmas(res);
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "whole: the larger of the images' noise and the spread of the %zu views' own "
                "residuals (a cluster-robust covariance over views: %s%s)",
                views, os.from_shoot ? "the shoot's calibration, poses and lamps" : "",
                misfit ? (os.from_shoot ? " and the model's misfit" : "the model's misfit") : "");
  res->uncertainty_basis = buf;
}

}  // namespace

void estimate_uncertainty(ModelFit* m, const ObsSet& os, const FitOptions& opt, Solution* sol,
                          FitResult* res) {
  Core& c = m->core;
  if (!sol->problem) {
    // A fused solve: a problem of the parameter blocks alone, for what is held and what is free.
    ceres::Problem::Options po;
    sol->problem = std::make_unique<ceres::Problem>(po);
    for (const auto& [b, size] : sol->information_order) sol->problem->AddParameterBlock(b, size);
  }
  ceres::Problem* pb = sol->problem.get();
  const bool n_free = hold_free_exponent(m, pb, res);
  const bool psi_free = !pb->IsParameterBlockConstant(&c.psi);
  std::vector<Block> blocks = {{c.kd, 3, {"kd.r", "kd.g", "kd.b"}},
                               {c.ks, 3, {"ks.r", "ks.g", "ks.b"}}};
  if (psi_free) blocks.push_back({&c.psi, 1, {"fiber_angle"}});
  if (n_free) blocks.push_back({&c.logn, 1, {"log n"}});
  for (Block& b : m->blocks(pb)) blocks.push_back(std::move(b));

  // The normal equations where they apply (every fit without a texel map); Ceres' dense SVD
  // otherwise, or when asked (--ceres-covariance: the reference the tests compare with).
  NormalEquations normal;
  CeresCovariance ceres_cov(opt.threads);
  const CovarianceSource* source = nullptr;
  bool deficient = false;
  const bool given = !sol->information.empty();
  std::vector<const double*> order;
  for (const auto& b : sol->information_order) order.push_back(b.first);
  if (given ? normal.compute_given(pb, blocks, sol->information, order, &deficient)
            : !opt.ceres_covariance && normal.compute(pb, blocks, &deficient))
    source = &normal;
  else if (!given && (opt.ceres_covariance || !deficient) &&
           ceres_cov.compute(pb, blocks, m->full_correlation()))
    source = &ceres_cov;
  res->report.covariance = source == &normal ? "normal equations" : "ceres dense SVD";
  if (!source) {
    res->undetermined["covariance"] =
        "rank deficient: some combination of parameters is not determined by these "
        "observations; no uncertainty is reported rather than a false one";
    return;
  }
  const CovarianceSource& cov = *source;
  if (m->full_correlation()) correlation(cov, pb, blocks, res);
  // sigma^2 from the residuals (unweighted least squares); a grey set counts each value once,
  // and its three identical channels must not count as three measurements.
  const double dof = std::max(1.0, sol->values - static_cast<double>(m->parameters()));
  const double s2 = sol->rss / (os.grey ? 3 : 1) / dof * (os.grey ? 3 : 1);
  const SigmaOf sigma = [&](const double* b, int size) {
    std::vector<double> cv(static_cast<size_t>(size) * size);
    cov.block(b, b, cv.data());
    std::vector<double> d(size);
    for (int i = 0; i < size; ++i) d[i] = std::sqrt(std::max(cv[i * size + i], 0.0) * s2);
    return d;
  };
  core_sigmas(sigma, &c, n_free, psi_free, res);
  m->sigmas(sigma, pb, res);
  // A grey set's shared parameters (n, psi, ...) see each reading in all three channels, which
  // s2 above undoes; a colour parameter's channel sees it once, so its sigma takes s2 / 3 (test
  // Trust.GreyReadingsGiveSigmasTheErrorsMatch).
  if (os.grey)
    for (auto& [key, v] : res->sigma)
      if (v.size() == 3)
        for (double& x : v) x /= std::sqrt(3.0);
  drop_nonfinite_sigmas(res);
  res->sigma_noise_only = res->sigma;
  res->uncertainty_basis = "the images' noise (the residuals' spread pixel by pixel)";
  whole_uncertainty(m, os, opt, *sol, cov, pb, blocks, s2, n_free, psi_free, res);
}

}  // namespace aniso::fitting
