// fit/ internal: one pixel of the line model with its isotropic part (docs/models.md §3), with its
// derivatives written out by hand: the line part's from line_pixel.h, the isotropic part's
// (k_d,iso <N,L>^+ + k_s,iso (<N,H>^+)^n_iso, summed over the pixel's lights) here. Shared by the
// --fit-isotropic fit (fit/global/line_fit.cpp) and the comparison with the isotropic part alone
// (fit/global/isotropic_alternative.cpp); tests/test_fit.cpp checks it against automatic
// derivatives of models/line_model.h.
#pragma once
#include <cmath>

#include "fit/records/observations.h"
#include "fit/solvers/line_pixel.h"

namespace aniso::fitting {

// Parameters of the isotropic part as the fit moves them: k_d,iso (3), k_s,iso (3), log n_iso.
inline constexpr int kIsotropicParams = 7;

// The sums over pixel i's lights of E <N,L>^+ (bd), E (<N,H>^+)^n (bs) and E (<N,H>^+)^n ln<N,H>
// (dbs: the derivative of bs by log n, over n), per channel. Lights below the horizon give
// nothing, as in line_reflectance.
inline void isotropic_basis(const ObsSet& os, size_t i, double n, double bd[3], double bs[3],
                            double dbs[3]) {
  const Observation& o = os.obs[i];
  const LocalDir V = o.V;
  for (int c = 0; c < 3; ++c) bd[c] = bs[c] = dbs[c] = 0;
  for (uint32_t k = 0; k < o.num_lights; ++k) {
    const ObsLight& l = os.lights[o.first_light + k];
    const LocalDir L = l.L;
    if (!(L.n > 0.0)) continue;
    const double hu = L.u + V.u, hw = L.w + V.w, hn = L.n + V.n;
    const double hl = std::sqrt(hu * hu + hw * hw + hn * hn);
    const double nh = hl > 0.0 ? hn / hl : 0.0;
    double spec = 0, dspec = 0;
    if (nh > 0.0) {
      const double lg = std::log(nh);
      spec = std::exp(n * lg);
      dspec = spec * lg;
    }
    for (int c = 0; c < 3; ++c) {
      bd[c] += l.E[c] * L.n;
      bs[c] += l.E[c] * spec;
      dbs[c] += l.E[c] * dspec;
    }
  }
}

// Pixel i's residual under the isotropic part alone (k_d,iso, k_s,iso, n_iso), with the basis it
// was made of (isotropic_basis's bd, bs, dbs) for derivatives.
inline void isotropic_residual(const ObsSet& os, size_t i, const double* kd, const double* ks,
                               double n, double r[3], double bd[3], double bs[3], double dbs[3]) {
  isotropic_basis(os, i, n, bd, bs, dbs);
  for (int c = 0; c < 3; ++c) r[c] = kd[c] * bd[c] + ks[c] * bs[c] - os.obs[i].y[c];
}

// Pixel i's residual under the line model (k_d, k_s, log n, psi) plus the isotropic part `iso`,
// and where J is given the Jacobian blocks J[0] (3x3 k_d), J[1] (3x3 k_s), J[2] (log n), J[3]
// (psi), J[4] (3x7 isotropic), row-major; null blocks are skipped.
inline void line_isotropic_pixel(const ObsSet& os, size_t i, const double* kd, const double* ks,
                                 double logn, double psi, const double* iso, double r[3],
                                 double* const* J) {
  PixelDerivs d;
  line_pixel_derivs(os.obs[i], os.lights.data(), kd, ks, logn, psi, &d);
  const double n = std::exp(iso[6]);
  double bd[3], bs[3], dbs[3];
  isotropic_basis(os, i, n, bd, bs, dbs);
  for (int c = 0; c < 3; ++c) {
    r[c] = d.r[c] + iso[c] * bd[c] + iso[3 + c] * bs[c];
    if (!J) continue;
    for (int q = 0; q < 3; ++q) {
      if (J[0]) J[0][c * 3 + q] = q == c ? d.dkd[c] : 0.0;
      if (J[1]) J[1][c * 3 + q] = q == c ? d.dks[c] : 0.0;
    }
    if (J[2]) J[2][c] = d.dlogn[c];
    if (J[3]) J[3][c] = d.dpsi[c];
    if (J[4]) {
      double* row = J[4] + c * kIsotropicParams;
      for (int q = 0; q < kIsotropicParams; ++q) row[q] = 0.0;
      row[c] = bd[c];
      row[3 + c] = bs[c];
      row[6] = iso[3 + c] * dbs[c] * n;
    }
  }
}

}  // namespace aniso::fitting
