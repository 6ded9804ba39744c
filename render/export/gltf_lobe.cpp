#include "render/export/gltf_lobe.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "core/angles.h"
#include "core/error.h"
#include "models/evaluate.h"
#include "models/material_maps.h"

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

// The three ways glTF can hold the model's colours, each as a texel's whole-model error is
// computed from sums over the direction grid (the model is linear in k_d and k_s): F = k_d D +
// k_s S against the glTF BRDF (1 - max F0) base / pi <N,L> + F0 g (KHR_materials_specular's
// fresnel_mix at F = F0: Schlick's grazing rise left out, as the lobe's fit leaves it out).
enum class Mapping { kMetal, kDielectric, kSpecular };
constexpr Mapping kMappings[] = {Mapping::kMetal, Mapping::kDielectric, Mapping::kSpecular};
const char* mapping_name(Mapping m) {
  switch (m) {
    case Mapping::kMetal:
      return "metal (base colour = specular colour; no diffuse term)";
    case Mapping::kDielectric:
      return "dielectric (base colour from k_d, F0 = 0.04: the specular colour lost)";
    case Mapping::kSpecular:
      return "dielectric with KHR_materials_specular (base colour from k_d, specular colour "
             "from k_s)";
  }
  return "";
}

// The sums over the direction grid that one colour channel's error needs: the model's F with
// itself and with <N,L> and the GGX lobe g, and <N,L>, g with each other.
struct ChannelSums {
  double FF = 0, Fnl = 0, Fg = 0, nlnl = 0, nlg = 0, gg = 0;
};

// One mapping's colours for one texel and its squared error summed over the channels; `diel`
// the Lambert fit of k_d D (as an albedo), `f0_ks` k_s times the lobe's scale.
struct Colours {
  RGB base{0, 0, 0}, specular{1, 1, 1};
  double metallic = 0, rss = 0;
};
// The squared error summed over the channels for diffuse coefficients b (the glTF diffuse
// (1 - max F0) base / pi) and F0.
double channel_rss(const ChannelSums sums[3], const RGB& b, const RGB& f0) {
  double rss = 0;
  for (int k = 0; k < 3; ++k) {
    const ChannelSums& s = sums[k];
    rss += s.FF - 2 * (b[k] * s.Fnl + f0[k] * s.Fg) + b[k] * b[k] * s.nlnl +
           2 * b[k] * f0[k] * s.nlg + f0[k] * f0[k] * s.gg;
  }
  return std::max(rss, 0.0);
}

// A dielectric's colours at F0: the diffuse is the Lambert fit's colour scaled by one factor
// (least squares, at most what base <= 1 allows under glTF's (1 - max F0) dimming), so that its
// hue is k_d's even where the fit would want more than glTF can give.
Colours dielectric_at(const ChannelSums sums[3], const RGB& diel, const RGB& f0) {
  Colours c;
  const double f0max = std::max({f0[0], f0[1], f0[2]});
  const double dmax = std::max({diel[0], diel[1], diel[2]});
  double num = 0, den = 0;
  for (int k = 0; k < 3; ++k) {
    const double d = diel[k] / M_PI;
    num += d * (sums[k].Fnl - f0[k] * sums[k].nlg), den += d * d * sums[k].nlnl;
  }
  const double cap = dmax > 0 ? (1 - f0max) / dmax : 0;
  const double sd = den > 0 ? std::clamp(num / den, 0.0, cap) : 0;
  RGB b;
  for (int k = 0; k < 3; ++k) {
    b[k] = sd * diel[k] / M_PI;
    c.base[k] = f0max < 1 ? sd * diel[k] / (1 - f0max) : 0;
    c.specular[k] = f0[k] / 0.04;
  }
  c.rss = channel_rss(sums, b, f0);
  return c;
}

// One mapping's colours for one texel and its squared error summed over the channels; `diel`
// the Lambert fit of k_d D (as an albedo), `f0_ks` k_s times the lobe's scale.
Colours colours_for(Mapping mp, const ChannelSums sums[3], const RGB& diel, const RGB& f0_ks) {
  if (mp == Mapping::kMetal) {
    Colours c;
    RGB f0;
    for (int k = 0; k < 3; ++k) f0[k] = c.base[k] = std::clamp(f0_ks[k], 0.0, 1.0);
    c.metallic = 1;
    c.rss = channel_rss(sums, {0, 0, 0}, f0);
    return c;
  }
  if (mp == Mapping::kDielectric) {
    Colours c = dielectric_at(sums, diel, {0.04, 0.04, 0.04});
    c.specular = {1, 1, 1};
    return c;
  }
  // KHR_materials_specular: F0 = t k_s (the specular colour's hue kept), t over a grid up to
  // F0 <= 1, the diffuse as above at each: a strong k_s dims glTF's diffuse by (1 - max F0), so
  // the best F0 trades the lobe against the colour.
  const double top = std::max({f0_ks[0], f0_ks[1], f0_ks[2]});
  Colours best;
  best.rss = INFINITY;
  constexpr int kSteps = 40;
  for (int i = 0; i <= kSteps; ++i) {
    const double t = (top > 1 ? 1 / top : 1.0) * i / kSteps;
    const RGB f0{t * f0_ks[0], t * f0_ks[1], t * f0_ks[2]};
    const Colours c = dielectric_at(sums, diel, f0);
    if (c.rss < best.rss) best = c;
  }
  return best;
}

// The base colour, metallic and specular colour that best match the whole model, over the three
// mappings.
void choose_colours(const std::vector<Pair>& pairs, const std::vector<std::array<double, 3>>& full,
                    const std::vector<double>& ms, const std::vector<double>& g,
                    const Material& m_in, double scale, GltfPbr* out) {
  ChannelSums sums[3];
  RGB diel, f0_ks;
  double mm = 0;
  for (int k = 0; k < 3; ++k) {
    ChannelSums& s = sums[k];
    double dn = 0;  // the model without its lobe, against <N,L>: the Lambert fit
    for (size_t i = 0; i < pairs.size(); ++i) {
      const double f = full[i][k], nl = pairs[i].L.n;
      s.FF += f * f, s.Fnl += f * nl, s.Fg += f * g[i], s.nlnl += nl * nl, s.nlg += nl * g[i],
          s.gg += g[i] * g[i];
      dn += (f - m_in.ks[k] * ms[i]) * nl;
    }
    diel[k] = std::clamp(M_PI * dn / std::max(s.nlnl, 1e-300), 0.0, 1.0);
    f0_ks[k] = m_in.ks[k] * scale;
    mm += s.FF;
  }
  double err[3];
  Colours best;
  Mapping chosen = Mapping::kMetal;
  for (Mapping mp : kMappings) {
    const Colours c = colours_for(mp, sums, diel, f0_ks);
    err[static_cast<int>(mp)] = mm > 0 ? std::sqrt(c.rss / mm) : 0;
    if (mp == Mapping::kMetal || err[static_cast<int>(mp)] < err[static_cast<int>(chosen)])
      chosen = mp, best = c;
  }
  out->metallic = best.metallic;
  out->base_color = best.base;
  out->specular = chosen == Mapping::kSpecular;
  out->specular_color = best.specular;
  out->total_rel_rms = err[static_cast<int>(chosen)];
  out->other_rel_rms = INFINITY;
  for (Mapping mp : kMappings)
    if (mp != chosen) out->other_rel_rms = std::min(out->other_rel_rms, err[static_cast<int>(mp)]);
  char buf[600];
  std::snprintf(buf, sizeof buf,
                "%s: whole-model relative RMS %.3f; metal %.3f, dielectric %.3f, dielectric with "
                "KHR_materials_specular %.3f",
                mapping_name(chosen), out->total_rel_rms, err[0], err[1], err[2]);
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

namespace {

// The GGX lobe whose shape best matches the model's specular lobe ms (k_s = 1): roughness,
// strength, its least-squares scale, its values at the pairs and the shape's relative RMS.
struct LobeFit {
  double roughness = 0.5, strength = 0, scale = 0, rel_rms = INFINITY;
  std::vector<double> g;
};
LobeFit fit_lobe(const std::vector<Pair>& pairs, const std::vector<double>& ms) {
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
  LobeFit f;
  f.roughness = br, f.strength = bs, f.rel_rms = best;
  f.g = lobe(pairs, br, bs);
  fit_scale(ms, f.g, &f.scale);
  return f;
}

// The material with the fiber along u (glTF's rotation carries psi).
Material along_u(const Material& m_in) {
  Material m = m_in;
  m.fiber_angle_deg = 0;
  m.second_angle_deg = m_in.second_angle_deg - m_in.fiber_angle_deg;
  return m;
}

// Its specular lobe alone (k_s = 1) at the pairs: the line lobe, or where the material has none
// and an isotropic one (the isotropic part alone a fit writes where the data show no anisotropic
// lobe), its Blinn-Phong lobe.
std::vector<double> specular_lobe(const std::vector<Pair>& pairs, const Material& m) {
  Material spec = along_u(m);
  const bool blinn_phong = m.ks[0] + m.ks[1] + m.ks[2] <= 0 && m.has_isotropic &&
                           m.iso_ks[0] + m.iso_ks[1] + m.iso_ks[2] > 0;
  spec.kd = {0, 0, 0};
  spec.ks = blinn_phong ? RGB{0, 0, 0} : RGB{1, 1, 1};
  spec.has_isotropic = blinn_phong;
  spec.iso_kd = {0, 0, 0};
  spec.iso_ks = {1, 1, 1};
  spec.has_second_fiber = false;
  spec.maps = MaterialMaps{};
  const Evaluator es(spec);
  std::vector<double> ms(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    double f[3];
    es(pairs[i].L, pairs[i].V, f);
    ms[i] = f[0];
  }
  return ms;
}

}  // namespace

GltfPbr fit_gltf_pbr(const Material& m_in) {
  GltfPbr out;
  const std::vector<Pair> pairs = direction_pairs();
  out.samples = pairs.size();
  // The model with the fiber along u: its specular lobe (k_s = 1) and its whole reflectance.
  const std::vector<double> ms = specular_lobe(pairs, m_in);
  const Evaluator ef(along_u(m_in));
  std::vector<std::array<double, 3>> full(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) ef(pairs[i].L, pairs[i].V, full[i].data());
  const LobeFit f = fit_lobe(pairs, ms);
  out.roughness = f.roughness;
  out.strength = f.strength;
  out.lobe_rel_rms = f.rel_rms;
  out.rotation_rad = wrap_half_turn(deg_to_rad(m_in.fiber_angle_deg + 90.0));
  choose_colours(pairs, full, ms, f.g, m_in, f.scale, &out);
  return out;
}

namespace {

// A node of log n for the texels: the lobe's fit and the sums over the pairs that the colours
// need (D: the diffuse term at k_d = 1, S: the lobe at k_s = 1, nl: <N,L>, g: the GGX lobe).
struct PbrNode {
  double logn = 0, roughness = 0, strength = 0, scale = 0;
  double DD = 0, DS = 0, SS = 0, Dnl = 0, Snl = 0, Dg = 0, Sg = 0, nlnl = 0, nlg = 0, gg = 0;
};

// (1 - a) x + a y, member by member: a texel between two nodes of log n.
PbrNode lerp(const PbrNode& x, const PbrNode& y, double a) {
  auto l = [a](double p, double q) { return (1 - a) * p + a * q; };
  return {l(x.logn, y.logn),
          l(x.roughness, y.roughness),
          l(x.strength, y.strength),
          l(x.scale, y.scale),
          l(x.DD, y.DD),
          l(x.DS, y.DS),
          l(x.SS, y.SS),
          l(x.Dnl, y.Dnl),
          l(x.Snl, y.Snl),
          l(x.Dg, y.Dg),
          l(x.Sg, y.Sg),
          l(x.nlnl, y.nlnl),
          l(x.nlg, y.nlg),
          l(x.gg, y.gg)};
}

}  // namespace

GltfPbrTexels fit_gltf_pbr_texels(const Material& m, int w, int h) {
  if (m.fiber() || m.isotropic_active() || m.second_active())
    throw Error(
        "glTF per texel: the plain line model only (a fiber model's or optional terms' "
        "maps take the mean values)");
  GltfPbrTexels out;
  out.w = w, out.h = h;
  const size_t N = static_cast<size_t>(w) * h;
  // The material at texel t's centre (looked up twice rather than held: ~300 bytes a texel).
  auto at = [&](size_t t) {
    return material_at(m, (static_cast<double>(t % w) + 0.5) / w,
                       (static_cast<double>(t / w) + 0.5) / h);
  };
  double lo = INFINITY, hi = -INFINITY;
  for (size_t t = 0; t < N; ++t) {
    const double logn = std::log(at(t).n);
    lo = std::min(lo, logn), hi = std::max(hi, logn);
  }
  const std::vector<Pair> pairs = direction_pairs();
  // Nodes at most 15 % apart in n (the lobe's shape changes slowly with n), at most 24.
  const int K =
      hi - lo < 1e-9
          ? 1
          : std::clamp(static_cast<int>(std::ceil((hi - lo) / std::log(1.15))) + 1, 2, 24);
  out.n_nodes = K;
  std::vector<PbrNode> nodes(K);
  Material dif = along_u(m);
  dif.maps = MaterialMaps{};
  dif.kd = {1, 1, 1}, dif.ks = {0, 0, 0};
  std::vector<double> D(pairs.size());
  {
    const Evaluator ed(dif);
    for (size_t i = 0; i < pairs.size(); ++i) {
      double f[3];
      ed(pairs[i].L, pairs[i].V, f);
      D[i] = f[0];
    }
  }
  tbb::parallel_for(0, K, [&](int k) {
    PbrNode& nd = nodes[k];
    nd.logn = K == 1 ? lo : lo + (hi - lo) * k / (K - 1);
    Material mk = dif;
    mk.n = std::exp(nd.logn);
    const std::vector<double> S = specular_lobe(pairs, mk);
    const LobeFit f = fit_lobe(pairs, S);
    nd.roughness = f.roughness, nd.strength = f.strength, nd.scale = f.scale;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const double d = D[i], s = S[i], nl = pairs[i].L.n, g = f.g[i];
      nd.DD += d * d, nd.DS += d * s, nd.SS += s * s, nd.Dnl += d * nl, nd.Snl += s * nl;
      nd.Dg += d * g, nd.Sg += s * g, nd.nlnl += nl * nl, nd.nlg += nl * g, nd.gg += g * g;
    }
  });
  out.base_color.resize(3 * N);
  for (auto* v : {&out.metallic, &out.roughness, &out.strength, &out.rotation_rad}) v->resize(N);
  // Each texel's sums and colours under the three mappings (from the node pair around its log n,
  // the sums linear in log n between them), then the one mapping with the least whole-model
  // error over every texel (relative, each texel weighted alike): per texel, 3-8 % of a fitted
  // map's texels chose the other of metal and dielectric and showed as specks.
  // A texel's sums (from the node pair around its log n, linear in log n between them) and its
  // fiber direction: one material lookup for all three mappings.
  struct TexelSums {
    ChannelSums sums[3];
    RGB diel, f0_ks;
    double mm = 0, fiber_deg = 0;
    PbrNode nd;
    // The mapping's colours and their whole-model relative error.
    Colours colours(Mapping mp, double* rel) const {
      const Colours col = colours_for(mp, sums, diel, f0_ks);
      *rel = mm > 0 ? std::sqrt(col.rss / mm) : 0;
      return col;
    }
  };
  auto texel = [&](size_t t) {
    const Material mt = at(t);
    TexelSums x;
    x.fiber_deg = mt.fiber_angle_deg;
    const double pos =
        K == 1 ? 0 : std::clamp((std::log(mt.n) - lo) / (hi - lo) * (K - 1), 0.0, K - 1.0);
    const int k0 = std::min(static_cast<int>(pos), K - 1), k1 = std::min(k0 + 1, K - 1);
    const PbrNode& nd = x.nd = lerp(nodes[k0], nodes[k1], pos - k0);
    for (int c = 0; c < 3; ++c) {
      const double kd = mt.kd[c], ks = mt.ks[c];
      ChannelSums& cs = x.sums[c];
      cs.FF = kd * kd * nd.DD + 2 * kd * ks * nd.DS + ks * ks * nd.SS;
      cs.Fg = kd * nd.Dg + ks * nd.Sg, cs.Fnl = kd * nd.Dnl + ks * nd.Snl;
      cs.nlnl = nd.nlnl, cs.nlg = nd.nlg, cs.gg = nd.gg;
      x.diel[c] = std::clamp(M_PI * kd * nd.Dnl / std::max(nd.nlnl, 1e-300), 0.0, 1.0);
      x.f0_ks[c] = ks * nd.scale;
      x.mm += cs.FF;
    }
    return x;
  };
  double sum2[3] = {0, 0, 0};
  for (size_t t = 0; t < N; ++t) {
    const TexelSums x = texel(t);
    for (Mapping mp : kMappings) {
      double rel;
      x.colours(mp, &rel);
      sum2[static_cast<int>(mp)] += rel * rel;
    }
  }
  Mapping chosen = Mapping::kMetal;
  for (Mapping mp : kMappings)
    if (sum2[static_cast<int>(mp)] < sum2[static_cast<int>(chosen)]) chosen = mp;
  char buf[600];
  std::snprintf(buf, sizeof buf,
                "%s for every texel: whole-model relative RMS over the texels metal %.3f, "
                "dielectric %.3f, dielectric with KHR_materials_specular %.3f",
                mapping_name(chosen), std::sqrt(sum2[0] / N), std::sqrt(sum2[1] / N),
                std::sqrt(sum2[2] / N));
  out.mapping = buf;
  out.specular = chosen == Mapping::kSpecular;
  if (out.specular) out.specular_color.resize(3 * N);
  double worst = 0;
  for (size_t t = 0; t < N; ++t) {
    const TexelSums x = texel(t);
    double rel;
    const Colours col = x.colours(chosen, &rel);
    for (int c = 0; c < 3; ++c) {
      out.base_color[3 * t + c] = static_cast<float>(col.base[c]);
      if (out.specular) out.specular_color[3 * t + c] = static_cast<float>(col.specular[c]);
    }
    out.metallic[t] = static_cast<float>(col.metallic);
    out.roughness[t] = static_cast<float>(x.nd.roughness);
    out.strength[t] = static_cast<float>(x.nd.strength);
    out.rotation_rad[t] = static_cast<float>(wrap_half_turn(deg_to_rad(x.fiber_deg + 90.0)));
    worst = std::max(worst, rel);
  }
  out.worst_total_rel_rms = worst;
  return out;
}

}  // namespace aniso
