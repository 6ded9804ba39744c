// fit/ internal: one pixel of the plain line model (docs/models.md §3) with its derivatives,
// written out by hand: the residual exposure * I - y per channel and d/d(k_d, k_s, log n, psi).
// Shared by the Ceres cost (LineResidualAnalytic) and the per-texel Levenberg-Marquardt of --maps,
// so the two solve exactly the same function. d sqrt(1 - a^2)/da uses the chord of
// models/safe_math.h below kSqrtChordEps.
#pragma once
#include <cmath>

#include "fit/records/observations.h"
#include "models/safe_math.h"

namespace aniso::fitting {

struct PixelDerivs {
  double r[3];                               // residual per channel
  double dkd[3], dks[3], dlogn[3], dpsi[3];  // d r_k / d k_d[k], d k_s[k], d log n, d psi
};

// sqrt(1 - a^2) and its derivative, with the chord of models/safe_math.h near |a| = 1.
inline void sin_and_derivative(double a, double* s, double* ds) {
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

// The parameters' transcendental parts, computed once per pass rather than per pixel.
struct LinePixelParams {
  const double *kd, *ks;
  double n, c, sn;  // n = exp(log n), cos psi, sin psi
};

inline void line_pixel_derivs(const Observation& o, const ObsLight* lights,
                              const LinePixelParams& p, PixelDerivs* d) {
  const double* kd = p.kd;
  const double* ks = p.ks;
  const double n = p.n, c = p.c, sn = p.sn;
  const LocalDir& V = o.V;
  const double b = clamp_unit(c * V.u + sn * V.w), db = -sn * V.u + c * V.w;
  double sV, dsV;
  sin_and_derivative(b, &sV, &dsV);
  double f[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k) d->dkd[k] = d->dks[k] = d->dlogn[k] = d->dpsi[k] = 0;
  for (uint32_t i = 0; i < o.num_lights; ++i) {
    const ObsLight& l = lights[o.first_light + i];
    const double nl = l.L.n;
    const double a = clamp_unit(c * l.L.u + sn * l.L.w), da = -sn * l.L.u + c * l.L.w;
    double sL, dsL;
    sin_and_derivative(a, &sL, &dsL);
    const double x = sL * sV - a * b;
    double S = 0, dS_dx = 0, dS_dlogn = 0;
    if (x > 0) {
      const double lx = std::log(x);
      S = std::exp(n * lx);
      dS_dx = n * S / x;
      dS_dlogn = S * n * lx;
    }
    const double dx_dpsi = (dsL * sV - b) * da + (sL * dsV - a) * db;
    const double dD_dpsi = dsL * da;
    for (int k = 0; k < 3; ++k) {
      const double w = l.E[k] * nl;
      f[k] += w * (kd[k] * sL + ks[k] * S);
      d->dkd[k] += w * sL;
      d->dks[k] += w * S;
      d->dlogn[k] += w * ks[k] * dS_dlogn;
      d->dpsi[k] += w * (kd[k] * dD_dpsi + ks[k] * dS_dx * dx_dpsi);
    }
  }
  for (int k = 0; k < 3; ++k) d->r[k] = f[k] - o.y[k];
}

inline void line_pixel_derivs(const Observation& o, const ObsLight* lights, const double kd[3],
                              const double ks[3], double logn, double psi, PixelDerivs* d) {
  line_pixel_derivs(o, lights,
                    LinePixelParams{kd, ks, std::exp(logn), std::cos(psi), std::sin(psi)}, d);
}

}  // namespace aniso::fitting
