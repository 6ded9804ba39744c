// Uncertainty of a solution (MODELS.md §6): coordinates the data leave free are held and named,
// the covariance of the rest comes from Ceres (rank deficiency fails rather than giving a zero
// variance), scaled by the residual variance; sigmas that say nothing become "undetermined".
#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/angles.h"
#include "fit/solve.h"

namespace aniso::fitting {

namespace {

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
void correlation(const ceres::Covariance& cov, ceres::Problem* pb, const std::vector<Block>& blocks,
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
  if (cb.empty() || !cov.GetCovarianceMatrix(cb, c.data())) {
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
void core_sigmas(const SigmaOf& sigma, Core* c, bool n_free, FitResult* res) {
  res->sigma["kd"] = sigma(c->kd, 3);
  res->sigma["ks"] = sigma(c->ks, 3);
  const double spsi = rad_to_deg(sigma(&c->psi, 1)[0]);
  // A lone light along T (s_L -> 0), or no lobe.
  constexpr double kPsiUndeterminedDeg = 10.0;
  if (spsi > kPsiUndeterminedDeg)
    res->undetermined["fiber_angle_deg"] =
        "sigma " + std::to_string(spsi) + " deg: the data barely constrain psi";
  else
    res->sigma["fiber_angle_deg"] = {spsi};
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

}  // namespace

void estimate_uncertainty(ModelFit* m, const ObsSet& os, const FitOptions& opt, Solution* sol,
                          FitResult* res) {
  ceres::Problem* pb = sol->problem.get();
  const bool n_free = hold_free_exponent(m, pb, res);
  Core& c = m->core;
  std::vector<Block> blocks = {{c.kd, 3, {"kd.r", "kd.g", "kd.b"}},
                               {c.ks, 3, {"ks.r", "ks.g", "ks.b"}},
                               {&c.psi, 1, {"fiber_angle"}}};
  if (n_free) blocks.push_back({&c.logn, 1, {"log n"}});
  for (Block& b : m->blocks(pb)) blocks.push_back(std::move(b));

  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = 0;  // rank deficiency must fail, never produce a zero variance
  co.min_reciprocal_condition_number = 1e-14;
  co.num_threads = std::max(1, opt.threads);
  ceres::Covariance cov(co);
  bool computed;
  if (m->full_correlation()) {
    std::vector<const double*> list;
    for (const Block& b : blocks) list.push_back(b.values);
    computed = cov.Compute(list, pb);  // every pair of blocks
  } else {
    std::vector<std::pair<const double*, const double*>> pairs;
    for (const Block& b : blocks) pairs.push_back({b.values, b.values});
    computed = cov.Compute(pairs, pb);
  }
  if (!computed) {
    res->undetermined["covariance"] =
        "rank deficient: some combination of parameters is not determined by these "
        "observations; no uncertainty is reported rather than a false one";
    return;
  }
  if (m->full_correlation()) correlation(cov, pb, blocks, res);
  // sigma^2 from the residuals (unweighted least squares); a grey set counts each value once,
  // and its three identical channels must not count as three measurements.
  const double dof = std::max(1.0, sol->values - static_cast<double>(m->parameters()));
  const double s2 = sol->rss / (os.grey ? 3 : 1) / dof * (os.grey ? 3 : 1);
  const SigmaOf sigma = [&](const double* b, int size) {
    std::vector<double> cv(static_cast<size_t>(size) * size);
    cov.GetCovarianceBlock(b, b, cv.data());
    std::vector<double> d(size);
    for (int i = 0; i < size; ++i) d[i] = std::sqrt(std::max(cv[i * size + i], 0.0) * s2);
    return d;
  };
  core_sigmas(sigma, &c, n_free, res);
  m->sigmas(sigma, pb, res);
  drop_nonfinite_sigmas(res);
}

}  // namespace aniso::fitting
