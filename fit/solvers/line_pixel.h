// fit/ internal: one pixel of the plain line model (docs/models.md §3) with its derivatives by
// hand (the equation itself in fit/solvers/line_equation.h): the residual exposure * I - y per
// channel and d/d(k_d, k_s, log n, psi).
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

#define LE_INLINE inline
#include "fit/solvers/line_equation.inc"
#undef LE_INLINE

// The scalar primitives of fit/solvers/line_equation.inc.
struct ScalarLineOps {
  static double clamp_unit(double a) { return aniso::clamp_unit(a); }
  static void sin(double a, double* s, double* ds) { sin_and_derivative(a, s, ds); }
  static double exp(double t) { return std::exp(t); }
  static double lit(double x, double a, double b) { return x > 0 ? a : b; }
};

inline void line_pixel_derivs(const Observation& o, const ObsLight* lights,
                              const LinePixelParams& p, PixelDerivs* d) {
  const double* kd = p.kd;
  const double* ks = p.ks;
  const LineView<double> view = line_view<ScalarLineOps, double>(p.c, p.sn, o.V.u, o.V.w);
  double f[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k) d->dkd[k] = d->dks[k] = d->dlogn[k] = d->dpsi[k] = 0;
  for (uint32_t i = 0; i < o.num_lights; ++i) {
    const ObsLight& l = lights[o.first_light + i];
    const double nl = l.L.n;  // E (float) times <N, L> in double
    const LineLight<double> g = line_light<ScalarLineOps, double>(p.c, p.sn, l.L.u, l.L.w, view);
    const double xs = g.x > 0 ? g.x : 1;
    const LineLobe<double> lobe = line_lobe<ScalarLineOps, double>(p.n, g.x, xs, std::log(xs));
    for (int k = 0; k < 3; ++k) {
      const double w = l.E[k] * nl;
      f[k] += w * (kd[k] * g.sL + ks[k] * lobe.S);
      d->dkd[k] += w * g.sL;
      d->dks[k] += w * lobe.S;
      d->dlogn[k] += w * ks[k] * lobe.dS_dlogn;
      d->dpsi[k] += w * (kd[k] * g.dD_dpsi + ks[k] * lobe.dS_dx * g.dx_dpsi);
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
