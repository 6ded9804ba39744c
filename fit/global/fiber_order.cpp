#include "fit/global/fiber_order.h"

#include <cmath>
#include <cstdio>

#include "fit/solvers/fiber_solve.h"

namespace aniso::fitting {

FiberOrderChoice choose_fiber_order(const ObsSet& os, const std::vector<size_t>& subset,
                                    const Core& c, const std::function<double(size_t)>& s_of) {
  constexpr int kReference = FiberOrderErrors::kMaxOrder, kSample = 400;
  constexpr int kOrders[] = {3, 4, 6, 8, 12};
  constexpr int kCount = sizeof kOrders / sizeof kOrders[0];
  FiberOrderChoice ch;
  if (!(os.pixel_noise > 0) || subset.empty()) {
    ch.note = "; quadrature order 8 (no noise estimate of the images: the default)";
    return ch;
  }
  const double values = 3.0 * static_cast<double>(os.obs.size());
  ch.errors.noise = os.pixel_noise;
  const double tolerance = ch.errors.allowed(values);
  const double cp = std::cos(c.psi), sp = std::sin(c.psi), n = std::exp(c.logn);
  double sq[kCount] = {};
  size_t counted = 0;
  const size_t step = std::max<size_t>(1, subset.size() / kSample);
  for (size_t j = 0; j < subset.size(); j += step) {
    const Observation& o = os.obs[subset[j]];
    const double s = s_of(subset[j]);
    double f[kCount + 1][3];
    for (int k = 0; k <= kCount; ++k) {
      FiberAccuracy acc;
      acc.order = k < kCount ? kOrders[k] : kReference;
      double dcol[3] = {0, 0, 0}, scol[3] = {0, 0, 0};
      fiber_columns(os, o, cp, sp, n, s, acc, dcol, scol);
      for (int ch3 = 0; ch3 < 3; ++ch3) f[k][ch3] = c.kd[ch3] * dcol[ch3] + c.ks[ch3] * scol[ch3];
    }
    for (int k = 0; k < kCount; ++k)
      for (int ch3 = 0; ch3 < 3; ++ch3) {
        const double e = f[k][ch3] - f[kCount][ch3];
        sq[k] += e * e;
      }
    counted += 3;
  }
  ch.order = kReference;
  ch.rms_error = 0;
  static_assert(kCount <= FiberOrderErrors::kMaxOrders, "the orders tried fit the table");
  for (int k = 0; k < kCount; ++k) {
    const double rms = std::sqrt(sq[k] / static_cast<double>(counted));
    if (std::isfinite(rms)) {  // (a NaN is never kept, here as before)
      FiberOrderErrors& e = ch.errors;
      e.order[e.count] = kOrders[k], e.rms[e.count] = rms, ++e.count;
    }
    if (rms <= tolerance) {
      ch.order = kOrders[k];
      ch.rms_error = rms;
      break;
    }
  }
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "; quadrature order %d (its error %.2g RMS per value against order %d, under "
                "%.0f %% of noise %.3g / sqrt(%.0f values))",
                ch.order, ch.rms_error, kReference, 100 * FiberOrderErrors::kShare, os.pixel_noise,
                values);
  ch.note = buf;
  return ch;
}

}  // namespace aniso::fitting
