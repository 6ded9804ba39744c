// The forward model of docs/models.md §2 at one surface point: ambient plus, for every light above
// the horizon and not occluded, irradiance times the material's reflectance at the point's
// topology. The simulator uses it with shadow rays, `aniso verify` without; `occluded(sp, L, dist,
// cnt)` decides shadowing.
#pragma once
#include <cstddef>
#include <vector>

#include "core/frame.h"
#include "models/evaluate.h"
#include "models/light.h"

namespace aniso {

struct ShadeCounters {
  size_t light_evals = 0, shadow_rays = 0, below_horizon = 0;
};

template <class Occluded>
void shade_point(const Evaluator& eval, const SurfacePoint& sp, const Vec3& eye,
                 const std::vector<Light>& lights, const RGB& ambient_term, double topology_s,
                 Occluded&& occluded, double I[3], ShadeCounters* cnt,
                 std::vector<uint8_t>* light_used = nullptr) {
  const LocalDir Vl = to_local(sp, normalize(eye - sp.P));
  for (int c = 0; c < 3; ++c) I[c] = ambient_term[c];
  for (size_t li = 0; li < lights.size(); ++li) {
    Vec3 L;
    RGB E;
    double dist;
    if (!light_at(lights[li], sp.P, &L, &E, &dist)) continue;
    const LocalDir Ll = to_local(sp, L);
    if (!(Ll.n > 0.0)) {  // below the horizon: contributes nothing, so it is not evaluated
      ++cnt->below_horizon;
      continue;
    }
    if (occluded(sp, L, dist, cnt)) continue;
    double f[3];
    eval(Ll, Vl, f, topology_s);
    ++cnt->light_evals;
    if (light_used) (*light_used)[li] = 1;
    for (int c = 0; c < 3; ++c) I[c] += E[c] * f[c];
  }
}

}  // namespace aniso
