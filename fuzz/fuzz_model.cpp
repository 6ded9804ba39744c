// libFuzzer target: the models on arbitrary inputs. Any direction pair, any exponent, any
// topology: the result must be finite and non-negative (docs/models.md §6). Build: scripts/fuzz.sh.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "models/evaluate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  double v[10] = {0};
  std::memcpy(v, data, std::min(size, sizeof v));
  for (double& x : v)
    if (!std::isfinite(x)) x = 0.5;
  auto unit = [](double x, double y, double z) {
    const double l = std::sqrt(x * x + y * y + z * z);
    return l > 0 && std::isfinite(l) ? aniso::LocalDir{x / l, y / l, z / l}
                                     : aniso::LocalDir{0, 0, 1};
  };
  const aniso::LocalDir L = unit(v[0], v[1], v[2]), V = unit(v[3], v[4], v[5]);
  aniso::Material m;
  m.n = 1.0 + std::fmod(std::abs(v[6]), 1e4 - 1);
  m.fiber_angle_deg = std::fmod(v[7], 180.0);
  const double s = std::fmod(std::abs(v[8]), 1.0);
  for (const aniso::Model model : {aniso::Model::kLine, aniso::Model::kFiber}) {
    m.model = model;
    const aniso::Evaluator e(m);
    double f[3];
    e(L, V, f, s);
    for (double x : f)
      if (!std::isfinite(x) || x < 0) std::abort();
  }
  return 0;
}
