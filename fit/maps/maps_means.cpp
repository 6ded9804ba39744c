#include "fit/maps/maps_means.h"

#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "models/params.h"

namespace aniso {

MapsMeans maps_means(const TexelMaps& m) {
  MapsMeans r;
  r.has_s = !m.s.empty() && m.s_key == "s";
  double c2 = 0, s2 = 0;
  double kd2[3] = {}, ks2[3] = {}, n2 = 0, psi2 = 0, s_2 = 0;
  // A texel's sigma counts at most as its parameter's prior spread (bounds' width / sqrt 12): a
  // determined texel whose n the data barely touch carries a sigma near float's largest, which
  // squared would make the mean's sigma infinite.
  static const double kd_cap = line_param("kd").spread(), ks_cap = line_param("ks").spread(),
                      n_cap = line_param("n").spread(),
                      psi_cap = line_param("fiber_angle_deg").spread(),
                      s_cap = line_param("topology.s").spread();
  auto sq = [](double sigma, double cap) {
    const double x = std::isfinite(sigma) ? std::min(std::abs(sigma), cap) : cap;
    return x * x;
  };
  for (size_t t = 0; t < m.determined.size(); ++t) {
    if (!m.determined[t]) continue;
    ++r.texels;
    for (int c = 0; c < 3; ++c) {
      r.kd[c] += m.kd[3 * t + c], r.ks[c] += m.ks[3 * t + c];
      kd2[c] += sq(m.kd_sigma[3 * t + c], kd_cap);
      ks2[c] += sq(m.ks_sigma[3 * t + c], ks_cap);
    }
    r.n += m.n[t], n2 += sq(m.n_sigma[t], n_cap);
    const double a = 2 * m.psi_deg[t] * M_PI / 180;
    c2 += std::cos(a), s2 += std::sin(a);
    psi2 += sq(m.psi_sigma_deg[t], psi_cap);
    if (r.has_s) r.s += m.s[t], s_2 += sq(m.s_sigma[t], s_cap);
  }
  if (r.texels == 0) return r;
  const double k = static_cast<double>(r.texels);
  for (int c = 0; c < 3; ++c) {
    r.kd[c] /= k, r.ks[c] /= k;
    r.kd_sigma[c] = std::sqrt(kd2[c]) / k, r.ks_sigma[c] = std::sqrt(ks2[c]) / k;
  }
  r.n /= k, r.n_sigma = std::sqrt(n2) / k;
  r.psi_deg = wrap_fiber_deg(0.5 * std::atan2(s2, c2) * 180 / M_PI);
  r.psi_sigma_deg = std::sqrt(psi2) / k;
  if (r.has_s) r.s /= k, r.s_sigma = std::sqrt(s_2) / k;
  return r;
}

}  // namespace aniso
