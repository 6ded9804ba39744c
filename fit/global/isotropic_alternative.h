// fit/ internal: does the data show an anisotropic lobe at all? The fitted material against the
// line model's isotropic part alone (Lambert + Blinn-Phong: k_d,iso <N,L>^+ + k_s,iso
// (<N,H>^+)^n_iso, docs/models.md §3) by BIC on the same values (docs/models.md §6, "An isotropic
// alternative"). A material the data do not tell from an isotropic one has no fiber direction to
// report, however small its sigma.
#pragma once
#include <cstddef>

#include "fit/records/observations.h"

namespace aniso::fitting {

// At most this many observations (every k-th) take part in the comparison: a lobe that counts
// moves BIC by thousands over them; where the isotropic material is written, it is fitted again
// on at most kIsotropicWrittenObservations.
inline constexpr size_t kIsotropicTestObservations = 5000;
inline constexpr size_t kIsotropicWrittenObservations = 200000;
// A difference of BIC below this is weak evidence for either model (Kass & Raftery's "very
// strong" starts at 10).
inline constexpr double kBicStrong = 10.0;

// The share of the signal's energy (sum of |y|^2) a model with an anisotropic lobe must draw
// beyond the isotropic part alone (about 3 % of its amplitude) for the lobe to count as shown;
// below it a lobe draws a shape the Blinn-Phong lobe misses, not an anisotropy (docs/models.md §6
// gives the shares of the tests' files).
inline constexpr double kLobeShare = 1e-3;

struct IsotropicFit {
  double kd[3] = {0, 0, 0}, ks[3] = {0, 0, 0}, n = 20;
  double cost = 0;  // sum of rho(|r|^2) over the observations fitted (the plain squares without
                    // a loss), as the fit's own loss counts its residuals
  double rss = 0;   // sum of |r|^2 over the same observations
  bool converged = true;
  double sigma_kd[3] = {}, sigma_ks[3] = {}, sigma_n = 0;  // residual-scaled; 0 where not known
  bool n_determined = true;  // false where k_s,iso is about 0: no lobe to measure n_iso from
};

// The isotropic part alone fitted to obs[0], obs[stride], ... under the fit's loss (--loss at
// `loss_scale`): a grid over n_iso with k_d,iso and k_s,iso solved per channel (non-negative
// least squares), then the fused solver over all seven numbers from the best node (or from
// `from` where given); Ceres where `sigmas` are asked (the material written) or opt.ceres_solver.
// With `sigmas`, the residual-scaled standard deviations too.
IsotropicFit fit_isotropic_part(const ObsSet& os, size_t stride, const FitOptions& opt,
                                double loss_scale, const IsotropicFit* from = nullptr,
                                bool sigmas = false);

// Compares `res` (the fitted material, of `res.report.parameters` numbers) with the isotropic
// part alone, both under the fit's loss (BIC with the sum of rho in place of the sum of squares),
// and records the comparison in res->report.anisotropy. Where the isotropic one has
// the lower BIC, the material becomes it (fitted again, with its sigma) and
// the fiber direction and n are undetermined; with `keep_anisotropic` the material stays and
// only says so. Not for --maps, --global or per-pixel topology (returns without a test).
void test_isotropic_alternative(const ObsSet& os, const FitOptions& opt, FitResult* res);

}  // namespace aniso::fitting
