#include "render/bake/environment.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "io/images/image_io.h"

namespace aniso {

namespace {

// The clamped cosine max(cos x, 0) as a Fourier series: 1/pi + cos(x)/2 + 2 cos(2x)/(3 pi)
// - 2 cos(4x)/(15 pi) + ... (no odd term past the first); the tables keep these.
constexpr double kC0 = 1 / M_PI, kC1 = 0.5, kC2 = 2 / (3 * M_PI), kC4 = -2 / (15 * M_PI);

}  // namespace

Vec3 cell_direction(int x, int y, int w, int h) {
  const double phi = 2 * M_PI * (x + 0.5) / w, theta = M_PI * (y + 0.5) / h;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

Environment read_environment(const std::string& path) {
  Environment env;
  env.name = path;
  env.radiance = read_image(path).image;
  const Image& r = env.radiance;
  if (r.channels < 3)
    throw Error(path + ": an environment needs three channels (RGB radiance), it has " +
                std::to_string(r.channels));
  if (r.width != 2 * r.height || r.height < 2)
    throw Error(path + ": an equirectangular environment is twice as wide as high; this one is " +
                std::to_string(r.width) + "x" + std::to_string(r.height));
  for (size_t i = 0; i < r.px.size(); ++i)
    if (!(std::isfinite(r.px[i]) && r.px[i] >= 0))
      throw Error(path + ": pixel " + std::to_string(i / r.channels % r.width) + "," +
                  std::to_string(i / r.channels / r.width) +
                  " holds a value that is not a finite radiance >= 0");
  if (r.channels > 3) {
    Image rgb(r.width, r.height, 3);
    for (size_t p = 0; p < static_cast<size_t>(r.width) * r.height; ++p)
      for (int c = 0; c < 3; ++c) rgb.px[3 * p + c] = r.px[p * r.channels + c];
    env.radiance = std::move(rgb);
  }
  return env;
}

Environment studio_environment() {
  Environment env;
  env.name = "studio";
  const int w = 128, h = 64;
  env.radiance = Image(w, h, 3);
  // A soft-edged disc of `radius` degrees about `axis`, of `value`.
  struct Light {
    Vec3 axis;
    double radius_deg;
    RGB value;
  };
  const Light lights[] = {{normalize(Vec3(0.2, -0.3, 1.0)), 25, {4, 4, 4}},
                          {normalize(Vec3(1.0, -0.6, 0.3)), 20, {0.9, 0.7, 0.5}},
                          {normalize(Vec3(-0.6, 1.0, 0.4)), 15, {0.4, 0.55, 0.8}}};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec3 d = cell_direction(x, y, w, h);
      RGB v = d.z > 0 ? RGB{0.02, 0.02, 0.02} : RGB{0.01, 0.01, 0.01};
      for (const Light& l : lights) {
        const double angle = std::acos(std::clamp(dot(d, l.axis), -1.0, 1.0)) * 180 / M_PI;
        const double t = std::clamp((l.radius_deg - angle) / 4 + 0.5, 0.0, 1.0);  // 4 deg edge
        for (int c = 0; c < 3; ++c) v[c] += t * l.value[c];
      }
      for (int c = 0; c < 3; ++c) env.radiance.at(x, y, c) = static_cast<float>(v[c]);
    }
  return env;
}

Environment named_environment(const std::string& name) {
  return name == "studio" ? studio_environment() : read_environment(name);
}

EnvironmentSamples environment_samples(const Environment& env, int w, int h) {
  const Image& r = env.radiance;
  EnvironmentSamples s;
  // Each cell averages the source pixels whose centres fall in it, weighted by their solid angle.
  std::vector<double> sum(static_cast<size_t>(w) * h * 3, 0), area(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < r.height; ++y) {
    const double theta = M_PI * (y + 0.5) / r.height;
    const double d_omega = (2 * M_PI / r.width) * (M_PI / r.height) * std::sin(theta);
    const int cy = std::min(h - 1, y * h / r.height);
    for (int x = 0; x < r.width; ++x) {
      const size_t cell = static_cast<size_t>(cy) * w + std::min(w - 1, x * w / r.width);
      for (int c = 0; c < 3; ++c) sum[3 * cell + c] += r.at(x, y, c) * d_omega;
      area[cell] += d_omega;
    }
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t cell = static_cast<size_t>(y) * w + x;
      if (!(area[cell] > 0)) continue;
      s.dir.push_back(cell_direction(x, y, w, h));
      s.weight.push_back({sum[3 * cell], sum[3 * cell + 1], sum[3 * cell + 2]});
    }
  return s;
}

const char* environment_unsupported(const Material& m) {
  return m.second_active() && m.maps.fiber != nullptr ? "a second fiber with a map of the fiber "
                                                        "direction"
                                                      : nullptr;
}

IsotropicEnvironment prefilter_isotropic_environment(const Environment& env, double n_iso, int w,
                                                     int h, int env_w, int env_h) {
  const auto t0 = std::chrono::steady_clock::now();
  IsotropicEnvironment out;
  out.w = w, out.h = h;
  out.irradiance.assign(static_cast<size_t>(w) * h * 3, 0.f);
  out.glossy.assign(static_cast<size_t>(w) * h * 3, 0.f);
  const EnvironmentSamples s = environment_samples(env, env_w, env_h);
  const double np = std::max(n_iso / 4, 0.0);
  tbb::parallel_for(0, w * h, [&](int cell) {
    const Vec3 D = cell_direction(cell % w, cell / w, w, h);
    double irr[3] = {0, 0, 0}, gl[3] = {0, 0, 0};
    for (size_t k = 0; k < s.dir.size(); ++k) {
      const double c = dot(D, s.dir[k]);
      if (!(c > 0)) continue;
      const double lobe = std::pow(c, np);
      for (int ch = 0; ch < 3; ++ch)
        irr[ch] += s.weight[k][ch] * c, gl[ch] += s.weight[k][ch] * lobe;
    }
    for (int ch = 0; ch < 3; ++ch) {
      out.irradiance[static_cast<size_t>(cell) * 3 + ch] = static_cast<float>(irr[ch]);
      out.glossy[static_cast<size_t>(cell) * 3 + ch] = static_cast<float>(gl[ch]);
    }
  });
  // The factor: with N = z and V at <N,V> = c, the Blinn-Phong lobe summed over the half-vectors H
  // round N (dOmega_L = 4 <V,H> dOmega_H), where L = 2 <V,H> H - V is above the surface, over the
  // Phong lobe's 2 pi / (n_iso / 4 + 1).
  const int nt = 128, np_steps = 128;
  const double theta_max = std::min(M_PI / 2, 8 / std::sqrt(n_iso + 1));
  const double dt = theta_max / nt, dp = 2 * M_PI / np_steps, phong = 2 * M_PI / (np + 1);
  for (int i = 0; i < IsotropicEnvironment::kScaleNodes; ++i) {
    const double c = std::max(double(i) / (IsotropicEnvironment::kScaleNodes - 1), 1e-3);
    const Vec3 V{std::sqrt(1 - c * c), 0, c};
    double sum = 0;
    for (int a = 0; a < nt; ++a) {
      const double th = (a + 0.5) * dt, lobe = std::pow(std::cos(th), n_iso) * std::sin(th);
      for (int b = 0; b < np_steps; ++b) {
        const double ph = (b + 0.5) * dp;
        const Vec3 H{std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
        const double vh = dot(V, H);
        if (!(vh > 0) || !(2 * vh * H.z - V.z > 0)) continue;
        sum += lobe * 4 * vh * dt * dp;
      }
    }
    out.scale[i] = static_cast<float>(sum / phong);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

EnvironmentParts prefilter_environment_parts(const Environment& env, const BakeTables& tables,
                                             const Material* with_n) {
  auto unit_part = [&](bool specular, const Image* level = nullptr) {
    BakeTables u = tables;
    const Image& one = level ? *level : specular ? tables.specular : tables.diffuse;
    u.combined = Image(one.width, one.height, 3);
    for (size_t p = 0; p < static_cast<size_t>(one.width) * one.height; ++p)
      for (int c = 0; c < 3; ++c) u.combined.px[p * 3 + c] = one.px[p];
    return u;
  };
  EnvironmentParts parts;
  parts.diffuse = prefilter_environment(env, unit_part(false));
  if (!with_n || !with_n->maps.n) {
    parts.specular = prefilter_environment(env, unit_part(true));
  } else {
    const SpecularStack st = bake_material_stack(*with_n, tables.size, tables.index, 0.2, 16);
    for (const Image& level : st.S) {
      parts.specular_n.push_back(prefilter_environment(env, unit_part(true, &level)));
      parts.specular.seconds += parts.specular_n.back().seconds;
    }
    parts.logn0 = st.logn0, parts.log_step = st.log_step();
  }
  return parts;
}

std::vector<float> environment_parts_d_volume(const EnvironmentParts& p) {
  std::vector<float> v;
  for (const auto& term : p.diffuse.terms) v.insert(v.end(), term.begin(), term.end());
  return v;
}

std::vector<float> environment_parts_s_volume(const EnvironmentParts& p) {
  const EnvironmentTables& e = p.diffuse;  // (the same sizes)
  const int L = std::max<int>(1, static_cast<int>(p.specular_n.size()));
  const size_t row = static_cast<size_t>(e.w) * 3;
  std::vector<float> v(static_cast<size_t>(7) * e.nb * L * e.h * row);
  for (int t = 0; t < 7; ++t)
    for (int kn = 0; kn < L; ++kn) {
      const std::vector<float>& src =
          p.specular_n.empty() ? p.specular.terms[t] : p.specular_n[kn].terms[t];
      for (int i = 0; i < e.nb; ++i)
        for (int y = 0; y < e.h; ++y)
          std::copy_n(&src[(static_cast<size_t>(i) * e.h + y) * row], row,
                      &v[((static_cast<size_t>(t) * e.nb + i) * L * e.h + kn * e.h + y) * row]);
    }
  return v;
}

void chi_frame(const Vec3& T, Vec3* e1, Vec3* e2) {
  Vec3 a = cross(Vec3(0, 0, 1), T);
  if (length(a) < 1e-6) a = cross(Vec3(1, 0, 0), T);
  *e1 = normalize(a);
  *e2 = cross(T, *e1);
}

EnvironmentTables prefilter_environment(const Environment& env, const BakeTables& tables, int w,
                                        int h, int nb, int env_w, int env_h) {
  const auto t0 = std::chrono::steady_clock::now();
  if (tables.combined.channels != 3 || tables.size < 2)
    throw Error("environment: the material's combined table is needed");
  EnvironmentTables out;
  out.w = w, out.h = h, out.nb = nb, out.env_w = env_w, out.env_h = env_h;
  const EnvironmentSamples s = environment_samples(env, env_w, env_h);
  for (auto& t : out.terms) t.assign(static_cast<size_t>(w) * h * nb * 3, 0.f);
  // The table's rows at each level of b, and the texel coordinate of a cosine (bake.h).
  const int n = tables.size;
  std::vector<int> row0(nb);
  std::vector<double> row_t(nb);
  for (int i = 0; i < nb; ++i) {
    const double b = -std::cos(M_PI * i / (nb - 1));
    const double yc = std::clamp(texel_coord(b, n, tables.index), 0.0, n - 1.0);
    row0[i] = std::min(n - 2, static_cast<int>(yc));
    row_t[i] = yc - row0[i];
  }
  const Image& C = tables.combined;
  tbb::parallel_for(0, w * h, [&](int cell) {
    const int x = cell % w, y = cell / w;
    const Vec3 T = cell_direction(x, y, w, h);
    Vec3 e1, e2;
    chi_frame(T, &e1, &e2);
    // The table is bilinear in (a, b) and a depends on L alone: the environment's weighted basis
    // is gathered once per table column (split between the two columns a falls between), then
    // each level sums the columns' values against it: samples + levels x columns work for a
    // direction T, not samples x levels.
    std::vector<double> column(static_cast<size_t>(n) * 7 * 3, 0.0);
    std::vector<char> used(n, 0);
    for (size_t k = 0; k < s.dir.size(); ++k) {
      const Vec3& L = s.dir[k];
      const double a = std::clamp(dot(L, T), -1.0, 1.0);
      const double p = dot(L, e1), q = dot(L, e2);
      const double r2 = p * p + q * q;
      const double c2 = r2 > 0 ? (p * p - q * q) / std::sqrt(r2) : 0,
                   s2 = r2 > 0 ? 2 * p * q / std::sqrt(r2) : 0;
      const double c4 = r2 > 0 ? (c2 * c2 - s2 * s2) / std::sqrt(r2) : 0,
                   s4 = r2 > 0 ? 2 * c2 * s2 / std::sqrt(r2) : 0;
      const double rr = std::sqrt(r2);
      const double basis[7] = {kC0 * rr, kC1 * p, kC1 * q, kC2 * c2, kC2 * s2, kC4 * c4, kC4 * s4};
      const double xc = std::clamp(texel_coord(a, n, tables.index), 0.0, n - 1.0);
      const int x0 = std::min(n - 2, static_cast<int>(xc));
      const double tx = xc - x0;
      used[x0] = used[x0 + 1] = 1;
      for (int t = 0; t < 7; ++t)
        for (int c = 0; c < 3; ++c) {
          const double wb = s.weight[k][c] * basis[t];
          column[(static_cast<size_t>(x0) * 7 + t) * 3 + c] += (1 - tx) * wb;
          column[(static_cast<size_t>(x0 + 1) * 7 + t) * 3 + c] += tx * wb;
        }
    }
    std::vector<double> acc(static_cast<size_t>(nb) * 7 * 3, 0.0);
    for (int i = 0; i < nb; ++i) {
      const int y0 = row0[i];
      const double ty = row_t[i];
      for (int xt = 0; xt < n; ++xt) {
        if (!used[xt]) continue;
        for (int c = 0; c < 3; ++c) {
          const double f = (1 - ty) * C.at(xt, y0, c) + ty * C.at(xt, y0 + 1, c);
          for (int t = 0; t < 7; ++t)
            acc[(static_cast<size_t>(i) * 7 + t) * 3 + c] +=
                f * column[(static_cast<size_t>(xt) * 7 + t) * 3 + c];
        }
      }
    }
    for (int i = 0; i < nb; ++i)
      for (int t = 0; t < 7; ++t)
        for (int c = 0; c < 3; ++c)
          out.terms[t][((static_cast<size_t>(i) * h + y) * w + x) * 3 + c] =
              static_cast<float>(acc[(static_cast<size_t>(i) * 7 + t) * 3 + c]);
  });
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace aniso
