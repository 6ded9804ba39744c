#include "render/bake/environment_fiber.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"

namespace aniso {

namespace {

// cos(k chi) and sin(k chi) for k = 0..order from the projection (p, q) of a direction on the
// frame round T (r = |(p, q)|): the basis of the tables' terms, 1 at t = 0 where r is 0.
void chi_basis(double p, double q, int order, double* basis) {
  const double r = std::hypot(p, q);
  const double c = r > 0 ? p / r : 1, s = r > 0 ? q / r : 0;
  double ck = 1, sk = 0;
  basis[0] = 1;
  for (int k = 1; k <= order; ++k) {
    const double c2 = ck * c - sk * s, s2 = sk * c + ck * s;
    ck = c2, sk = s2;
    basis[2 * k - 1] = r > 0 ? ck : 0;
    basis[2 * k] = r > 0 ? sk : 0;
  }
}

// The level of b (acos(-b) = pi i / (nb - 1)).
double level_b(int i, int nb) { return -std::cos(M_PI * i / (nb - 1)); }

}  // namespace

FiberEnvironmentTables prefilter_fiber_environment(const Environment& env, const Material& m,
                                                   const BakeTables& line,
                                                   const FiberBakeTables& fb, int order, int w,
                                                   int h, int nb, int nphi, int env_w, int env_h) {
  const auto t0 = std::chrono::steady_clock::now();
  if (line.specular.channels != 1 || line.size < 2)
    throw Error("environment: the material's specular table is needed");
  if (fb.G.empty() || fb.F.empty()) throw Error("environment: the fiber tables are needed");
  if (order < 1 || order > 8 || nb < 2 || nphi < 2)
    throw Error("environment: the fiber tables' sizes are out of range");
  FiberEnvironmentTables out;
  out.order = order, out.w = w, out.h = h, out.nb = nb, out.nphi = nphi;
  out.env_w = env_w, out.env_h = env_h;
  const int nt = out.terms();
  const EnvironmentSamples es = environment_samples(env, env_w, env_h);
  // S_line and F at each level of n: the material's one n, or levels over its map of n's range.
  std::vector<const Image*> S_levels{&line.specular};
  std::vector<std::vector<float>> F_levels;
  SpecularStack stack;
  if (m.maps.n) {
    stack = bake_material_stack(m, line.size, line.index, 0.2, 16);
    S_levels.clear();
    for (const Image& level : stack.S) S_levels.push_back(&level);
    out.logn0 = stack.logn0, out.log_step = stack.log_step();
    for (int k = 0; k < stack.levels; ++k) {
      F_levels.emplace_back(fb.F.size());
      bake_fiber_F(std::exp(stack.logn0 + k * stack.log_step()), fb.nphi, fb.ns, fb.nk,
                   F_levels.back().data());
    }
  }
  out.nn = static_cast<int>(S_levels.size());
  out.diffuse.assign(static_cast<size_t>(nt) * h * w * 3, 0.f);
  out.specular.assign(static_cast<size_t>(out.nn) * nt * nb * h * w * 3, 0.f);

  // The line table's rows at each level of b.
  const int n = line.size;
  std::vector<int> row0(nb);
  std::vector<double> row_t(nb);
  for (int i = 0; i < nb; ++i) {
    const double yc = std::clamp(texel_coord(level_b(i, nb), n, line.index), 0.0, n - 1.0);
    row0[i] = std::min(n - 2, static_cast<int>(yc));
    row_t[i] = yc - row0[i];
  }
  tbb::parallel_for(0, w * h, [&](int cell) {
    const int x = cell % w, y = cell / w;
    const Vec3 T = cell_direction(x, y, w, h);
    Vec3 e1, e2;
    chi_frame(T, &e1, &e2);
    // As the line model's prefilter: S_line is bilinear in (a, b) and a depends on L alone, so the
    // environment's basis is gathered per table column first, then summed per level of b.
    std::vector<double> column(static_cast<size_t>(n) * nt * 3, 0.0), diffuse(nt * 3, 0.0);
    std::vector<char> used(n, 0);
    std::vector<double> basis(nt);
    for (size_t k = 0; k < es.dir.size(); ++k) {
      const Vec3& L = es.dir[k];
      const double a = std::clamp(dot(L, T), -1.0, 1.0);
      const double p = dot(L, e1), q = dot(L, e2), sl = std::hypot(p, q);
      chi_basis(p, q, order, basis.data());
      const double xc = std::clamp(texel_coord(a, n, line.index), 0.0, n - 1.0);
      const int x0 = std::min(n - 2, static_cast<int>(xc));
      const double tx = xc - x0;
      used[x0] = used[x0 + 1] = 1;
      for (int t = 0; t < nt; ++t)
        for (int c = 0; c < 3; ++c) {
          const double wb = es.weight[k][c] * basis[t];
          diffuse[t * 3 + c] += sl * wb;
          column[(static_cast<size_t>(x0) * nt + t) * 3 + c] += (1 - tx) * wb;
          column[(static_cast<size_t>(x0 + 1) * nt + t) * 3 + c] += tx * wb;
        }
    }
    for (int t = 0; t < nt; ++t)
      for (int c = 0; c < 3; ++c)
        out.diffuse[((static_cast<size_t>(t) * h + y) * w + x) * 3 + c] =
            static_cast<float>(diffuse[t * 3 + c]);
    std::vector<double> acc(static_cast<size_t>(nt) * 3);
    for (int kn = 0; kn < out.nn; ++kn) {
      const Image& S = *S_levels[kn];
      for (int i = 0; i < nb; ++i) {
        std::fill(acc.begin(), acc.end(), 0.0);
        for (int xt = 0; xt < n; ++xt) {
          if (!used[xt]) continue;
          const double f =
              (1 - row_t[i]) * S.at(xt, row0[i], 0) + row_t[i] * S.at(xt, row0[i] + 1, 0);
          if (f == 0) continue;
          for (int q = 0; q < nt * 3; ++q)
            acc[q] += f * column[static_cast<size_t>(xt) * nt * 3 + q];
        }
        for (int t = 0; t < nt; ++t)
          for (int c = 0; c < 3; ++c)
            out.specular[((((static_cast<size_t>(kn) * nt + t) * nb + i) * h + y) * w + x) * 3 +
                         c] = static_cast<float>(acc[t * 3 + c]);
      }
    }
  });

  // F's and G's series in phi_l, from the factor tables, by the midpoint rule over the lit half
  // circle (both are 0 beyond it).
  const bool uniform = m.topology_as<UniformS>() != nullptr;
  out.ns = uniform ? 1 : fb.ns;
  const int kSteps = 360;
  const double dphi = M_PI / kSteps;
  out.coef.assign(static_cast<size_t>(out.nn) * out.ns * nb * nphi * 2 * nt, 0.f);
  tbb::parallel_for(0, nb * out.ns * out.nn, [&](int task) {
    const int i = task % nb, ks = task / nb % out.ns, kn = task / nb / out.ns;
    const float* Ftab = F_levels.empty() ? fb.F.data() : F_levels[kn].data();
    const double s = uniform ? std::clamp(m.uniform_s(), 0.0, 1.0) : double(ks) / (fb.ns - 1);
    const double b = level_b(i, nb), kappa = 2 * (1 - b * b);
    std::vector<double> cf(2 * nt);
    for (int j = 0; j < nphi; ++j) {
      const double phi_v = -M_PI / 2 + M_PI * j / (nphi - 1);
      std::fill(cf.begin(), cf.end(), 0.0);
      for (int k = 0; k < kSteps; ++k) {
        const double phi_l = -M_PI / 2 + (k + 0.5) * dphi;
        double G, F;
        fiber_factors(fb, Ftab, phi_l, phi_v, s, kappa, &G, &F);
        for (int part = 0; part < 2; ++part) {
          const double f = (part ? G : F) * dphi;
          double* c = &cf[part * nt];
          c[0] += f / (2 * M_PI);
          for (int o = 1; o <= order; ++o) {
            c[2 * o - 1] += f * std::cos(o * phi_l) / M_PI;
            c[2 * o] += f * std::sin(o * phi_l) / M_PI;
          }
        }
      }
      for (int q = 0; q < 2 * nt; ++q)
        out.coef[(((static_cast<size_t>(kn) * out.ns + ks) * nb + i) * nphi + j) * 2 * nt + q] =
            static_cast<float>(cf[q]);
    }
  });
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

std::vector<float> fiber_environment_specular_volume(const FiberEnvironmentTables& t) {
  if (t.nn == 1) return t.specular;
  const int nt = t.terms();
  const size_t row = static_cast<size_t>(t.w) * 3;
  std::vector<float> v(t.specular.size());
  for (int kn = 0; kn < t.nn; ++kn)
    for (int layer = 0; layer < nt * t.nb; ++layer)
      for (int y = 0; y < t.h; ++y)
        std::copy_n(&t.specular[((static_cast<size_t>(kn) * nt * t.nb + layer) * t.h + y) * row],
                    row, &v[((static_cast<size_t>(layer) * t.nn + kn) * t.h + y) * row]);
  return v;
}

std::vector<float> fiber_environment_coef_volume(const FiberEnvironmentTables& t) {
  const int nt = t.terms(), layers = t.coef_layers();
  std::vector<float> v(static_cast<size_t>(t.nn) * t.ns * layers * t.nb * t.nphi * 3, 0.f);
  for (int k = 0; k < t.nn * t.ns; ++k)  // level of n times ns plus level of s
    for (int l = 0; l < layers; ++l)
      for (int i = 0; i < t.nb; ++i)
        for (int j = 0; j < t.nphi; ++j)
          for (int c = 0; c < 3; ++c)
            if (const int q = 3 * l + c; q < 2 * nt)
              v[(((static_cast<size_t>(k) * layers + l) * t.nb + i) * t.nphi + j) * 3 + c] =
                  t.coef[((static_cast<size_t>(k) * t.nb + i) * t.nphi + j) * 2 * nt + q];
  return v;
}

void fiber_environment_at_node(const FiberEnvironmentTables& t, const Material& m, int x, int y,
                               int i, int j, int k, double chi_n, double out[3]) {
  const int nt = t.terms();
  const float* cf = &t.coef[((static_cast<size_t>(k) * t.nb + i) * t.nphi + j) * 2 * nt];
  double d[3] = {0, 0, 0}, s[3] = {0, 0, 0};
  auto add = [&](int term, double wf, double wg) {
    for (int c = 0; c < 3; ++c) {
      d[c] += wg * t.diffuse[((static_cast<size_t>(term) * t.h + y) * t.w + x) * 3 + c];
      s[c] +=
          wf * t.specular[(((static_cast<size_t>(term) * t.nb + i) * t.h + y) * t.w + x) * 3 + c];
    }
  };
  add(0, cf[0], cf[nt]);
  for (int o = 1; o <= t.order; ++o) {
    const double co = std::cos(o * chi_n), so = std::sin(o * chi_n);
    double fc, fs, gc, gs;
    fiber_environment_turn(cf[2 * o - 1], cf[2 * o], co, so, &fc, &fs);
    fiber_environment_turn(cf[nt + 2 * o - 1], cf[nt + 2 * o], co, so, &gc, &gs);
    add(2 * o - 1, fc, gc);
    add(2 * o, fs, gs);
  }
  for (int c = 0; c < 3; ++c) out[c] = m.kd[c] * d[c] + m.ks[c] * s[c];
}

}  // namespace aniso
