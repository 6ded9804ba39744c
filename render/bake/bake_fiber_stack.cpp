// The fiber model's factor F at many n (render/bake/bake.h: FiberStack).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "core/error.h"
#include "core/progress.h"
#include "core/random_dir.h"
#include "models/evaluate.h"
#include "models/fiber_model.h"
#include "render/bake/bake.h"

namespace aniso {

namespace {

// Where log n falls among `levels` levels from logn0 in steps of `step`: the lower level and the
// weight of the next, as the shaders compute it.
void level_of(double n, double logn0, double step, int levels, int* k0, double* w) {
  const double f =
      step > 0 ? std::clamp((std::log(n) - logn0) / step, 0.0, double(levels - 1)) : 0.0;
  *k0 = std::min(static_cast<int>(f), std::max(levels - 2, 0));
  *w = f - *k0;
}

}  // namespace

FiberStack bake_fiber_stack(const Material& m, const FiberBakeTables& fb, const BakeTables& line,
                            const SpecularStack& st, double max_log_step, int max_levels,
                            uint64_t seed, const ProgressSink* progress) {
  const auto t0 = std::chrono::steady_clock::now();
  FiberStack fs;
  fs.seed = seed;
  fs.logn0 = st.logn0;
  fs.logn1 = st.logn1;
  const int steps = static_cast<int>(std::ceil((fs.logn1 - fs.logn0) / max_log_step - 1e-9));
  fs.levels = std::clamp(steps + 1, 2, max_levels);
  fs.level_floats = static_cast<size_t>(fb.nphi) * fb.nphi * fb.ns * fb.nk;
  fs.F.assign(fs.level_floats * fs.levels, 0.f);
  {
    Progress bar("bake: fiber factor F over the map's n", fs.levels, progress);
    for (int k = 0; k < fs.levels; ++k, bar.advance())
      bake_fiber_F(std::exp(fs.logn0 + k * fs.log_step()), fb.nphi, fb.ns, fb.nk,
                   fs.F.data() + k * fs.level_floats);
  }
  fs.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // The whole lookup (D and G, S_line from its stack, F from this one) against the full model at
  // random L, V, s and n in the range (seeded), as bake_fiber measures its tables.
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double sum2 = 0;
  constexpr int kSamples = 20000;
  for (int it = 0; it < kSamples; ++it) {
    const LocalDir L = random_upper_dir(rng, g), V = random_upper_dir(rng, g);
    const double s = u(rng), n = std::exp(fs.logn0 + u(rng) * (fs.logn1 - fs.logn0));
    LineParamsT<double> p = fiber_frame_params(m);
    p.n = n;
    double ref[3], baked[3];
    fiber_reflectance(p, s, L, V, FiberAccuracy{}, ref);
    fiber_stack_eval(m, line, st, fb, fs, L, V, s, n, baked);
    for (int c = 0; c < 3; ++c) {
      const double e = std::abs(baked[c] - ref[c]);
      sum2 += e * e;
      fs.max_abs_error = std::max(fs.max_abs_error, e);
      fs.peak_value = std::max(fs.peak_value, ref[c]);
    }
    ++fs.samples;
  }
  fs.rms_error = std::sqrt(sum2 / (3.0 * fs.samples));
  return fs;
}

void fiber_stack_eval(const Material& m, const BakeTables& line, const SpecularStack& st,
                      const FiberBakeTables& fb, const FiberStack& fs, const LocalDir& L,
                      const LocalDir& V, double s, double n, double out[3]) {
  out[0] = out[1] = out[2] = 0;
  FiberCoords fc;
  if (!fiber_coords(L, V, &fc)) return;
  int k0;
  double w;
  level_of(n, fs.logn0, fs.log_step(), fs.levels, &k0, &w);
  double G, F0, F1 = 0;
  fiber_factors(fb, fs.level(k0), fc.phi_l, fc.phi_v, s, fc.kappa, &G, &F0);
  if (fs.levels > 1) fiber_factors(fb, fs.level(k0 + 1), fc.phi_l, fc.phi_v, s, fc.kappa, &G, &F1);
  const double F = F0 + w * (F1 - F0);
  const double Dl = lookup_bilinear(line.diffuse, fc.a, fc.b, 0, line.index);
  const double Sl = stack_lookup(st, fc.a, fc.b, n);
  for (int c = 0; c < 3; ++c) out[c] = m.kd[c] * Dl * G + m.ks[c] * Sl * F;
}

std::vector<float> fiber_stack_layers(const FiberBakeTables& fb, const FiberStack& fs) {
  const size_t np = fb.nphi, nk = fb.nk, width = nk * np;
  std::vector<float> out(fs.F.size());
  for (int k = 0; k < fs.levels; ++k)
    for (int is = 0; is < fb.ns; ++is) {
      const float* level = fs.level(k);
      float* layer = out.data() + (static_cast<size_t>(k) * fb.ns + is) * width * np;
      for (size_t ik = 0; ik < nk; ++ik)
        for (size_t j = 0; j < np; ++j)
          std::copy_n(level + ((is * nk + ik) * np + j) * np, np, layer + j * width + ik * np);
    }
  return out;
}

}  // namespace aniso
