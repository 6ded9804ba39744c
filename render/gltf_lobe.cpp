#include "render/gltf_lobe.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "core/angles.h"
#include "models/evaluate.h"

namespace aniso {

namespace {

struct Pair {
  LocalDir L, V;
};

// Light and view directions on a polar x azimuth grid over the hemisphere (cell centres).
std::vector<Pair> direction_pairs() {
  constexpr int kPolar = 8, kAzimuth = 16;
  std::vector<LocalDir> dirs;
  for (int i = 0; i < kPolar; ++i)
    for (int j = 0; j < kAzimuth; ++j) {
      const double th = (i + 0.5) * (M_PI / 2) / kPolar, ph = (j + 0.5) * 2 * M_PI / kAzimuth;
      dirs.push_back({std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)});
    }
  std::vector<Pair> pairs;
  for (const auto& L : dirs)
    for (const auto& V : dirs) pairs.push_back({L, V});
  return pairs;
}

double alpha_t_of(double roughness, double strength) {
  const double a = roughness * roughness;
  return a + (1 - a) * strength * strength;  // mix(alpha, 1, strength^2)
}

// Least-squares scale c of g onto m and the relative RMS of m - c g.
double fit_scale(const std::vector<double>& m, const std::vector<double>& g, double* c) {
  double mg = 0, gg = 0, mm = 0;
  for (size_t i = 0; i < m.size(); ++i) mg += m[i] * g[i], gg += g[i] * g[i], mm += m[i] * m[i];
  *c = gg > 0 ? mg / gg : 0;
  const double rss = std::max(0.0, mm - 2 * (*c) * mg + (*c) * (*c) * gg);
  return mm > 0 ? std::sqrt(rss / mm) : 0;
}

std::vector<double> lobe(const std::vector<Pair>& pairs, double r, double s) {
  std::vector<double> g(pairs.size());
  const double at = alpha_t_of(r, s), ab = r * r;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const auto& p = pairs[i];
    g[i] = ggx_aniso_lobe(p.L.u, p.L.w, p.L.n, p.V.u, p.V.w, p.V.n, at, ab);
  }
  return g;
}

// The base colour and metallic: a metal (base = the specular colour) or a dielectric (base = the
// Lambert fit of the diffuse term, F0 = 0.04), whichever matches the whole model better. Whole-
// model error: glTF diffuse (1 - metallic) base / pi <N,L> plus F0 * lobe with
// F0 = mix(0.04, base, metallic) (Schlick's grazing rise left out).
void choose_colours(const std::vector<Pair>& pairs, const std::vector<std::array<double, 3>>& full,
                    const std::vector<double>& ms, const std::vector<double>& g,
                    const Material& m_in, double scale, GltfPbr* out) {
  auto total_error = [&](double metallic, const RGB& base) {
    double rss = 0, mm = 0;
    for (size_t i = 0; i < pairs.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        const double f0 = 0.04 * (1 - metallic) + base[k] * metallic;
        const double v = (1 - metallic) * base[k] / M_PI * pairs[i].L.n + f0 * g[i];
        rss += (full[i][k] - v) * (full[i][k] - v);
        mm += full[i][k] * full[i][k];
      }
    return mm > 0 ? std::sqrt(rss / mm) : 0;
  };
  RGB metal, dielectric;
  for (int k = 0; k < 3; ++k) {
    metal[k] = std::clamp(m_in.ks[k] * scale, 0.0, 1.0);
    // Lambert albedo that best matches the model's diffuse k_d D <N,L>: base / pi = sum m nl /
    // sum nl^2 over the grid.
    double mn = 0, nn = 0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const double d = full[i][k] - m_in.ks[k] * ms[i];  // the model without its lobe
      mn += d * pairs[i].L.n, nn += pairs[i].L.n * pairs[i].L.n;
    }
    dielectric[k] = std::clamp(M_PI * mn / std::max(nn, 1e-300), 0.0, 1.0);
  }
  const double e_metal = total_error(1.0, metal), e_diel = total_error(0.0, dielectric);
  const bool is_metal = e_metal <= e_diel;
  out->metallic = is_metal ? 1.0 : 0.0;
  out->base_color = is_metal ? metal : dielectric;
  out->total_rel_rms = std::min(e_metal, e_diel);
  out->other_rel_rms = std::max(e_metal, e_diel);
  char buf[300];
  std::snprintf(buf, sizeof buf,
                "%s: whole-model relative RMS %.3f against %.3f for the %s mapping "
                "(a glTF metal has no diffuse term; a dielectric's specular is F0 = 0.04)",
                is_metal ? "metal (base colour = specular colour)"
                         : "dielectric (base colour = Lambert fit of the diffuse term)",
                out->total_rel_rms, out->other_rel_rms, is_metal ? "dielectric" : "metal");
  out->mapping = buf;
}
}  // namespace

double ggx_aniso_lobe(double lu, double lw, double ln, double vu, double vw, double vn,
                      double alpha_t, double alpha_b) {
  if (ln <= 0 || vn <= 0) return 0;
  double hu = lu + vu, hw = lw + vw, hn = ln + vn;
  const double hl = std::sqrt(hu * hu + hw * hw + hn * hn);
  if (!(hl > 0)) return 0;
  hu /= hl, hw /= hl, hn /= hl;
  alpha_t = std::max(alpha_t, 1e-4), alpha_b = std::max(alpha_b, 1e-4);
  // t = w (across the fiber), b = u (along it).
  const double a2 = alpha_t * alpha_b;
  const double x = hw / alpha_t, y = hu / alpha_b, d = x * x + y * y + hn * hn;
  const double D = 1.0 / (M_PI * a2 * d * d);
  const double gv =
      ln * std::sqrt(alpha_t * alpha_t * vw * vw + alpha_b * alpha_b * vu * vu + vn * vn);
  const double gl =
      vn * std::sqrt(alpha_t * alpha_t * lw * lw + alpha_b * alpha_b * lu * lu + ln * ln);
  const double vis = 0.5 / (gv + gl);
  return D * vis * ln;
}

GltfPbr fit_gltf_pbr(const Material& m_in) {
  GltfPbr out;
  const std::vector<Pair> pairs = direction_pairs();
  out.samples = pairs.size();
  // The model with the fiber along u: its specular lobe (k_s = 1) and its whole reflectance.
  Material m = m_in;
  m.fiber_angle_deg = 0;
  m.second_angle_deg = m_in.second_angle_deg - m_in.fiber_angle_deg;
  Material spec = m;
  spec.kd = {0, 0, 0};
  spec.ks = {1, 1, 1};
  spec.has_isotropic = false;
  spec.has_second_fiber = false;
  const Evaluator es(spec), ef(m);
  std::vector<double> ms(pairs.size());
  std::vector<std::array<double, 3>> full(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    double f[3];
    es(pairs[i].L, pairs[i].V, f);
    ms[i] = f[0];
    ef(pairs[i].L, pairs[i].V, full[i].data());
  }
  // Coarse grid over (roughness, strength), then two finer grids about the best node.
  double best = INFINITY, br = 0.5, bs = 0, step_r = 0.05, step_s = 0.05;
  auto search = [&](double r0, double r1, double s0, double s1, double dr, double ds) {
    for (double r = r0; r <= r1 + 1e-12; r += dr)
      for (double s = s0; s <= s1 + 1e-12; s += ds) {
        if (r < 0.01 || r > 1 || s < 0 || s > 1) continue;
        double c;
        const double e = fit_scale(ms, lobe(pairs, r, s), &c);
        if (e < best) best = e, br = r, bs = s;
      }
  };
  search(0.05, 1.0, 0.0, 1.0, step_r, step_s);
  for (int round = 0; round < 2; ++round) {
    const double dr = step_r / 5, ds = step_s / 5;
    search(br - step_r, br + step_r, bs - step_s, bs + step_s, dr, ds);
    step_r = dr, step_s = ds;
  }
  out.roughness = br;
  out.strength = bs;
  out.lobe_rel_rms = best;
  out.rotation_rad = wrap_half_turn(deg_to_rad(m_in.fiber_angle_deg + 90.0));
  double scale;
  const std::vector<double> g = lobe(pairs, br, bs);
  fit_scale(ms, g, &scale);

  choose_colours(pairs, full, ms, g, m_in, scale, &out);
  return out;
}

}  // namespace aniso
