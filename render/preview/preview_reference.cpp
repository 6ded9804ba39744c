#include "render/preview/preview_reference.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "core/angles.h"
#include "core/frame.h"
#include "core/texture.h"
#include "io/formats/capture.h"
#include "models/evaluate.h"
#include "models/material_maps.h"
#include "models/topology.h"

namespace aniso {

namespace {

// The frame of a covered fragment from the geometry pass; false where there is none.
bool fragment_frame(const GBuffer& g, const PreviewResult& res, int x, int y, SurfacePoint* sp) {
  if (!res.covered[static_cast<size_t>(y) * g.N.width + x]) return false;
  const Vec3 N{g.N.at(x, y, 0), g.N.at(x, y, 1), g.N.at(x, y, 2)},
      T{g.T.at(x, y, 0), g.T.at(x, y, 1), g.T.at(x, y, 2)};
  return make_frame(Vec3(0, 0, 0), N, T, sp);
}

// The largest value of any channel of a map, or of the scalar it replaces.
double largest(const std::shared_ptr<const Image>& map, const RGB& scalar) {
  double v = std::max({scalar[0], scalar[1], scalar[2]});
  if (map)
    for (float x : map->px) v = std::max(v, double(x));
  return v;
}

// The fiber model's topology s at a fragment of `local` (the material at the fragment), as the
// shaders' topology_at: from its mathematical topology (T2's third channel) and its map.
double fragment_s(const Material& local, const PreviewOptions& opt, const TopologyMap& map,
                  const GBuffer& g, int x, int y) {
  const double u = g.T2.at(x, y, 0), v = g.T2.at(x, y, 1), smath = g.T2.at(x, y, 2);
  const double mv = local.topology_as<SMapRef>() ? sample_first_channel(opt.s_map, u, v)
                    : map.h.empty()              ? 0.0
                                                 : map.sample(u, v);
  return s_at(local, smath, mv);
}

}  // namespace

void fiber_reference(const Material& m, const PreviewOptions& opt, const PreviewCamera& cam,
                     const std::vector<PreviewLight>& lights, const BakeTables& tables,
                     const FiberBakeTables& fb, const SpecularStack* stack,
                     const FiberStack* fstack, const GBuffer& g, PreviewResult* res) {
  const int w = g.N.width, h = g.N.height;
  res->reference = Image(w, h, 3);
  TopologyMap map;
  map.h = opt.topology_map;
  // With maps every fragment has its own k_d, k_s, fiber direction and amplitude, and n where the
  // pass has the stacks over the map of n (the material's n otherwise), as in the shader.
  const bool maps = m.maps.any(), psi_map = maps && m.maps.fiber != nullptr;
  const bool n_map = stack && fstack && fstack->levels > 0;
  double max_e = 0;  // the largest total irradiance at a fragment (point lights vary)
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      SurfacePoint sp;
      if (!fragment_frame(g, *res, x, y, &sp)) continue;
      Material local = maps ? material_at(m, g.UV.at(x, y, 0), g.UV.at(x, y, 1)) : m;
      if (!n_map) local.n = m.n;
      if (psi_map) {  // the frame turned by the map's psi: the fiber along its U, as the shader's T
        const double psi = deg_to_rad(local.fiber_angle_deg);
        make_frame(sp.P, sp.N, sp.U * std::cos(psi) + sp.W * std::sin(psi), &sp);
      }
      const double s = fragment_s(local, opt, map, g, x, y);
      Material line_only = local;
      line_only.model = Model::kLine;
      double exact[3] = {0, 0, 0}, baked[3] = {0, 0, 0}, esum = 0;
      const Vec3 P{g.P.at(x, y, 0), g.P.at(x, y, 1), g.P.at(x, y, 2)};
      const LocalDir Vl = to_local(sp, cam.toward_viewer(P));
      for (const PreviewLight& light : lights) {
        Vec3 Ld;
        double E;
        light.at(P, &Ld, &E);
        const LocalDir Ll = to_local(sp, Ld);
        esum += E;
        LineParamsT<double> p = line_params(local);
        p.psi = 0;
        double f[3], gb[3];
        fiber_reflectance(p, s, Ll, Vl, FiberAccuracy{}, f);
        if (n_map)
          fiber_stack_eval(line_only, tables, *stack, fb, *fstack, Ll, Vl, s, local.n, gb);
        else
          fiber_baked_eval(line_only, tables, fb, Ll, Vl, s, gb);
        for (int ch = 0; ch < 3; ++ch) exact[ch] += E * f[ch], baked[ch] += E * gb[ch];
      }
      max_e = std::max(max_e, esum);
      for (int ch = 0; ch < 3; ++ch) {
        res->reference.at(x, y, ch) = float(exact[ch]);
        const double got = res->rgb.at(x, y, ch);
        res->max_abs_diff = std::max(res->max_abs_diff, std::abs(got - exact[ch]));
        res->max_abs_diff_baked = std::max(res->max_abs_diff_baked, std::abs(got - baked[ch]));
      }
    }
  // The tables' error was measured at the material's k_d, k_s: maps that reach higher scale it.
  double scale = 1;
  if (maps)
    for (const auto& [map, scalar] : {std::pair{m.maps.kd, m.kd}, std::pair{m.maps.ks, m.ks}}) {
      const double top = std::max({scalar[0], scalar[1], scalar[2]});
      if (top > 0) scale = std::max(scale, largest(map, scalar) / top);
    }
  const double table_error = n_map ? fstack->max_abs_error : fb.max_abs_error;
  res->error_bound = max_e * table_error * scale + 1e-5;
}

void line_reference(const Material& m, const PreviewOptions& opt, const PreviewCamera& cam,
                    const std::vector<PreviewLight>& lights, const BakeTables& tables,
                    const SpecularStack* stack, const GBuffer& g, PreviewResult* res) {
  const int w = g.N.width, h = g.N.height;
  res->reference = Image(w, h, 3);
  // The largest texel step times the 8-bit sub-texel weight precision that hardware filtering is
  // allowed (and llvmpipe uses): what GL_LINEAR may add to the bake's own (measured) error.
  constexpr double kFilterWeightStep = 1.0 / 256.0, kFloatSlack = 1e-5;
  // The angle index's acos in single precision: near |x| = 1 an input rounding of 2^-24 moves
  // acos by up to sqrt(2 * 2^-24) = 3.5e-4 rad, i.e. that many texels times (N - 1) / pi.
  const bool angle = tables.index == BakeIndex::kAngle;
  const double acos_texels =
      angle ? std::sqrt(2.0 * std::ldexp(1.0, -24)) * (tables.size - 1) / M_PI : 0.0;
  const int lobes = m.second_active() ? 2 : 1;
  const double filter = 2 * (kFilterWeightStep + acos_texels);
  double unit_bound = lobes * (tables.max_abs_error + max_texel_step(tables.combined) * filter);
  const bool maps = m.maps.any();
  if (maps && stack) {
    // D and S apart, each times the largest k_d, k_s the maps hold (the maps themselves are
    // filtered in float by the shader, as here).
    const double kd = largest(m.maps.kd, m.kd), ks = largest(m.maps.ks, m.ks);
    unit_bound =
        lobes * (kd * (stack->diffuse_max_abs_error + max_texel_step(tables.diffuse) * filter) +
                 ks * (stack->max_abs_error + stack->max_texel_step * filter));
  }
  const bool psi_map = maps && m.maps.fiber != nullptr;
  double max_e = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      SurfacePoint sp;
      if (!fragment_frame(g, *res, x, y, &sp)) continue;
      const Vec3 T2{g.T2.at(x, y, 0), g.T2.at(x, y, 1), g.T2.at(x, y, 2)};
      // In the frame (U = T) the fiber angle is 0, or the fiber map's (then T is the reference
      // tangent, turned by the shader), and the second fiber sits at atan2(<T2,W>, <T2,T>).
      Material local = maps ? material_at(m, g.UV.at(x, y, 0), g.UV.at(x, y, 1)) : m;
      if (!psi_map) local.fiber_angle_deg = 0;
      local.second_angle_deg = rad_to_deg(std::atan2(dot(T2, sp.W), dot(T2, sp.U)));
      const Evaluator le(local);
      double acc[3] = {0, 0, 0}, esum = 0;
      const Vec3 P{g.P.at(x, y, 0), g.P.at(x, y, 1), g.P.at(x, y, 2)};
      const LocalDir Vl = to_local(sp, cam.toward_viewer(P));
      for (const PreviewLight& light : lights) {
        Vec3 Ld;
        double E, f[3];
        light.at(P, &Ld, &E);
        esum += E;
        le(to_local(sp, Ld), Vl, f);
        for (int ch = 0; ch < 3; ++ch) acc[ch] += E * f[ch];
      }
      max_e = std::max(max_e, esum);
      for (int ch = 0; ch < 3; ++ch) {
        res->reference.at(x, y, ch) = float(acc[ch]);
        res->max_abs_diff =
            std::max(res->max_abs_diff, std::abs(double(res->rgb.at(x, y, ch)) - acc[ch]));
      }
    }
  res->error_bound = max_e * unit_bound + kFloatSlack;
}

void environment_reference(const Material& m, const PreviewOptions& opt, const PreviewCamera& cam,
                           const Environment& env, int w, int h, const GBuffer& g,
                           PreviewResult* res) {
  const auto t0 = std::chrono::steady_clock::now();
  const EnvironmentSamples s = environment_samples(env, w, h);
  const int W = g.N.width, H = g.N.height;
  res->reference = Image(W, H, 3);
  // In the frame (U = T) the fiber angle is 0 and a second fiber's is its angle from the first, or
  // the fiber map's (then T is the reference tangent, turned by the shader); a material with maps
  // is evaluated at each fragment's uv.
  const bool maps = m.maps.any(), psi_map = maps && m.maps.fiber != nullptr;
  Material local = m;
  local.fiber_angle_deg = 0;
  local.second_angle_deg = m.second_angle_deg - m.fiber_angle_deg;
  const Evaluator uniform(local);
  TopologyMap map;
  map.h = opt.topology_map;
  tbb::parallel_for(0, H, [&](int y) {
    for (int x = 0; x < W; ++x) {
      SurfacePoint sp;
      if (!fragment_frame(g, *res, x, y, &sp)) continue;
      std::optional<Evaluator> at;
      Material here;
      if (maps) {
        here = material_at(m, g.UV.at(x, y, 0), g.UV.at(x, y, 1));
        if (!psi_map) {
          here.second_angle_deg = m.second_angle_deg - here.fiber_angle_deg;
          here.fiber_angle_deg = 0;
        }
        at.emplace(here);
      }
      const Evaluator& le = maps ? *at : uniform;
      const double topo = m.fiber() ? fragment_s(maps ? here : m, opt, map, g, x, y) : 0.0;
      const Vec3 P{g.P.at(x, y, 0), g.P.at(x, y, 1), g.P.at(x, y, 2)};
      const LocalDir Vl = to_local(sp, cam.toward_viewer(P));
      double acc[3] = {0, 0, 0};
      for (size_t k = 0; k < s.dir.size(); ++k) {
        const LocalDir Ll = to_local(sp, s.dir[k]);
        if (!(Ll.n > 0)) continue;
        double f[3];  // the model's reflectance per unit irradiance
        le(Ll, Vl, f, topo);
        for (int c = 0; c < 3; ++c) acc[c] += s.weight[k][c] * f[c];
      }
      for (int c = 0; c < 3; ++c) res->reference.at(x, y, c) = static_cast<float>(acc[c]);
    }
  });
  double sum_abs = 0, sum2 = 0, ref2 = 0, ref_sum = 0, max_abs = 0;
  size_t n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!res->covered[static_cast<size_t>(y) * W + x]) continue;
      for (int c = 0; c < 3; ++c) {
        const double r = res->reference.at(x, y, c), d = res->rgb.at(x, y, c) - r;
        sum_abs += std::abs(d), sum2 += d * d, ref2 += r * r, ref_sum += r;
        max_abs = std::max(max_abs, std::abs(d));
        ++n;
      }
    }
  res->max_abs_diff = max_abs;
  res->env_mean_abs = n ? sum_abs / n : 0;
  res->env_rel_rms = ref2 > 0 ? std::sqrt(sum2 / ref2) : 0;
  res->env_reference_mean = n ? ref_sum / n : 0;
  res->env_reference_directions = static_cast<int>(s.dir.size());
  res->env_reference_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace aniso
