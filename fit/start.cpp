#include "fit/start.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "core/angles.h"
#include "core/progress.h"

namespace aniso::fitting {

void set_start_kd_ks(const double kd[3], const double ks[3], Core* c) {
  for (int ch = 0; ch < 3; ++ch) {
    c->kd[ch] = std::max(kd[ch], 1e-4);
    c->ks[ch] = std::max(ks[ch], 1e-4);
  }
}

double line_node_cost(const ObsSet& os, const std::vector<size_t>& subset, double psi, double n,
                      double kd[3], double ks[3]) {
  const double c = std::cos(psi), s = std::sin(psi);
  return solve_kd_ks(
      os, subset,
      [&](const Observation& o, double* dcol, double* scol) {
        const double b = c * o.V.u + s * o.V.w;
        for (uint32_t k = 0; k < o.num_lights; ++k) {
          const ObsLight& l = os.lights[o.first_light + k];
          double D, S;
          line_DS(c * l.L.u + s * l.L.w, b, n, &D, &S);
          for (int ch = 0; ch < 3; ++ch) {
            dcol[ch] += l.E[ch] * l.L.n * D;
            scol[ch] += l.E[ch] * l.L.n * S;
          }
        }
      },
      kd, ks);
}

std::string line_grid_start(const ObsSet& os, Core* st, bool progress) {
  Progress bar("fit: start grid (psi x n)", 36, progress);
  const std::vector<size_t> subset = start_subset(os.obs.size(), kMaxStartObs);
  double best = std::numeric_limits<double>::infinity();
  double best_psi = 0, best_logn = 0, best_kd[3] = {0, 0, 0}, best_ks[3] = {0, 0, 0};
  for (int ip = 0; ip < 36; ++ip, bar.advance()) {
    const double psi = ip * M_PI / 36;
    for (int in = 1; in <= 12; ++in) {
      const double n = std::pow(2.0, in);
      double kd[3], ks[3];
      const double cost = line_node_cost(os, subset, psi, n, kd, ks);
      if (cost < best) {
        best = cost;
        best_psi = psi;
        best_logn = std::log(n);
        std::copy(kd, kd + 3, best_kd);
        std::copy(ks, ks + 3, best_ks);
      }
    }
  }
  st->psi = best_psi;
  st->logn = best_logn;
  set_start_kd_ks(best_kd, best_ks, st);
  char buf[160];
  std::snprintf(buf, sizeof buf, "grid psi=%.1f deg, n=%.0f (36 x 12 nodes on %zu pixels)",
                rad_to_deg(best_psi), std::exp(best_logn), subset.size());
  return buf;
}

}  // namespace aniso::fitting
