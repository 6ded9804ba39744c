// The fiber model under an environment (render/bake/environment_fiber.h): the prefiltered tables
// at their nodes against sums over the environment through the baked model and through the exact
// one; the preview's frame against brute force. And the optional terms of either model (a second
// fiber, the isotropic term) under an environment.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/error.h"
#include "datasets_synth/presets.h"
#include "models/evaluate.h"
#include "render/bake/bake.h"
#include "render/bake/environment.h"
#include "render/bake/environment_fiber.h"
#include "render/preview/preview.h"

namespace aniso {
namespace {

// Silk on a flat sample: one topology s for the whole surface.
Material flat_silk(double s, double n) {
  Material m;
  m.model = Model::kFiber;
  m.kd = {0.3, 0.22, 0.06};
  m.ks = {0.55, 0.5, 0.35};
  m.n = n;
  m.fiber_angle_deg = 30;
  m.topology = UniformS{s};
  return m;
}

// `m` rendered with `p` (against brute force where p asks), and how far apart `other` renders with
// the same options: the share of the first frame's sum.
double rendered_apart(const Material& m, const Material& other, const PreviewOptions& p,
                      PreviewResult* r) {
  *r = render_preview(m, p);
  PreviewOptions q = p;
  q.reference = false;
  const PreviewResult o = render_preview(other, q);
  double apart = 0, sum = 0;
  for (size_t k = 0; k < r->rgb.px.size(); ++k)
    apart += std::abs(r->rgb.px[k] - o.rgb.px[k]), sum += r->rgb.px[k];
  return sum > 0 ? apart / sum : 0;
}

TEST(FiberEnvironment, NodesAgreeWithSumsOverTheEnvironment) {
  const Environment studio = studio_environment();
  for (const auto& [s, n] : {std::pair{0.0, 30.0}, std::pair{0.4, 120.0}, std::pair{0.7, 8.0}}) {
    Material m = flat_silk(s, n);
    const BakeTables line = bake_line(m, 256);
    const FiberBakeTables fb = bake_fiber(m, line);
    const FiberEnvironmentTables et = prefilter_fiber_environment(studio, m, line, fb);
    const EnvironmentSamples es = environment_samples(studio, et.env_w, et.env_h);
    Material local = m;
    local.fiber_angle_deg = 0;
    const Evaluator ev(local);
    // The differences, over the brightest node's value: a dim node's relative error says little.
    double worst_series = 0, worst_bake = 0, brightest = 0;
    // Nodes where the studio's key light (overhead) falls on the fibres at several angles.
    const int nodes[][5] = {{10, 10, 12, 16, 0},
                            {40, 6, 20, 10, 1},
                            {20, 14, 16, 22, 2},
                            {52, 20, 9, 16, 3},
                            {5, 12, 14, 4, 4}};
    for (const auto& nd : nodes) {
      const int x = nd[0], y = nd[1], i = nd[2], j = nd[3];
      const Vec3 T = cell_direction(x, y, et.w, et.h);
      Vec3 e1, e2;
      chi_frame(T, &e1, &e2);
      const double chi_n = 0.9 * nd[4] - 1.2;
      const Vec3 N = e1 * std::cos(chi_n) + e2 * std::sin(chi_n), B = cross(N, T);
      const double b = -std::cos(M_PI * i / (et.nb - 1)),
                   phi_v = -M_PI / 2 + M_PI * j / (et.nphi - 1);
      const Vec3 V = T * b + (N * std::cos(phi_v) + B * std::sin(phi_v)) * std::sqrt(1 - b * b);
      const LocalDir Vl{dot(V, T), dot(V, B), dot(V, N)};
      double pre[3];
      fiber_environment_at_node(et, m, x, y, i, j, 0, chi_n, pre);
      double baked = 0, exact = 0;
      for (size_t k = 0; k < es.dir.size(); ++k) {
        const Vec3& L = es.dir[k];
        const LocalDir Ll{dot(L, T), dot(L, B), dot(L, N)};
        if (!(Ll.n > 0)) continue;
        double f[3], g[3];
        ev(Ll, Vl, f);
        fiber_baked_eval(local, line, fb, Ll, Vl, s, g);
        exact += es.weight[k][1] * f[1];
        baked += es.weight[k][1] * g[1];
      }
      std::printf(
          "s %.1f n %3.0f node (%d,%d,%d,%d): prefiltered %.5f, through the baked model "
          "%.5f, the exact model %.5f\n",
          s, n, x, y, i, j, pre[1], baked, exact);
      ASSERT_GT(exact, 0.005);
      worst_series = std::max(worst_series, std::abs(pre[1] - baked));
      worst_bake = std::max(worst_bake, std::abs(baked - exact));
      brightest = std::max(brightest, exact);
    }
    worst_series /= brightest, worst_bake /= brightest;
    std::printf(
        "s %.1f n %.0f: worst difference over the brightest node, prefiltered to baked "
        "%.4f, baked to exact %.4f (prefiltered in %.2f s)\n",
        s, n, worst_series, worst_bake, et.seconds);
    // The series cut at order 6, and F's kappa taken where S_line peaks.
    EXPECT_LT(worst_series, 0.03);
    EXPECT_LT(worst_bake, 0.02);
  }
}

// The preview's frame under the studio against brute force (the exact fiber model summed over the
// environment's directions at every fragment), on a flat sample and on a sphere.
TEST(FiberEnvironment, PreviewAgainstBruteForce) {
  const Environment studio = studio_environment();
  for (const char* shape : {"flat", "sphere"}) {
    const Material m = flat_silk(0.4, 40);
    PreviewOptions p;
    p.shape = shape;
    p.width = p.height = 48;
    p.view_dir = {0, -0.5, 1};
    p.reference = true;
    p.environment = &studio;
    p.repeat = 5;
    const PreviewResult r = render_preview(m, p);
    PreviewOptions one = p;
    one.environment = nullptr;
    one.reference = false;
    const PreviewResult l = render_preview(m, one);
    std::printf(
        "%s: prefiltered in %.2f s; against brute force (%.1f s): mean abs %.4g (mean %.4g), "
        "relative RMS %.4g, max %.4g; %.2f ms/frame against one light's %.2f (%s)\n",
        shape, r.env_prefilter_seconds, r.env_reference_seconds, r.env_mean_abs,
        r.env_reference_mean, r.env_rel_rms, r.max_abs_diff, 1e3 * r.seconds_per_frame,
        1e3 * l.seconds_per_frame, r.renderer.c_str());
    EXPECT_EQ(r.passes, 1);
    EXPECT_GT(r.env_reference_mean, 0.02);
    EXPECT_LT(r.env_rel_rms, 0.05);
  }
}

// The fiber model's topology per fragment under the studio: Hast's torus (the mathematical topology
// plus a topology map) and swirl-plate's maps of k_d and the fiber direction on a fiber material,
// each against brute force at every fragment's own s and material, and apart from the same
// material drawn with one s, or without its maps.
TEST(FiberEnvironment, TopologyAndMapsPerFragmentAgainstBruteForce) {
  const Environment studio = studio_environment();
  Material torus = flat_silk(0, 30);
  torus.fiber_angle_deg = 90;
  torus.topology = TopologyMapRef{"map.png", 0.25, MathTopology::kTorus};
  PreviewOptions tp;
  tp.shape = "torus";
  tp.shape_options.torus_r = 0.6;
  tp.view_dir = {0.3, -0.6, 0.75};
  tp.topology_map = procedural_topology_map(64, 3);
  PresetOptions po;
  po.views = 1;
  po.width = po.height = 16;
  po.progress = nullptr;
  Material swirl = make_preset("swirl-plate", po).truth;
  ASSERT_TRUE(swirl.maps.kd && swirl.maps.fiber && !swirl.maps.n);
  swirl.model = Model::kFiber;
  swirl.topology = UniformS{0.3};
  PreviewOptions sp;
  sp.shape = "flat";
  sp.view_dir = {0, -0.5, 1};
  for (auto [m, p] : {std::pair{torus, tp}, std::pair{swirl, sp}}) {
    p.width = p.height = 48;
    p.reference = true;
    p.environment = &studio;
    Material plain = m;
    if (m.maps.any())
      plain.maps = MaterialMaps{};
    else
      plain.topology = UniformS{0.5};
    PreviewResult r;
    const double apart = rendered_apart(m, plain, p, &r);
    std::printf(
        "%s: against brute force mean abs %.4g (mean %.4g), relative RMS %.4g, max %.4g; "
        "against %s %.0f %% of the image's sum apart\n",
        p.shape.c_str(), r.env_mean_abs, r.env_reference_mean, r.env_rel_rms, r.max_abs_diff,
        m.maps.any() ? "no maps" : "one s", 100 * apart);
    EXPECT_GT(r.env_reference_mean, 0.02);
    EXPECT_LT(r.env_rel_rms, 0.05);
    EXPECT_GT(apart, 0.03);
  }
}

// A second fiber (the same tables at T2) and the isotropic term (its irradiance and Phong tables)
// under the studio and a uniform environment, for the line and the fiber model and for the
// isotropic part alone (what a fit writes where no lobe counts), against brute force.
TEST(EnvironmentTerms, SecondFiberAndIsotropicTermAgainstBruteForce) {
  Environment uniform;
  uniform.name = "uniform";
  uniform.radiance = Image(64, 32, 3, 1.0f);
  const Environment studio = studio_environment();
  Material line;
  line.kd = {0.25, 0.1, 0.05};
  line.ks = {0.6, 0.55, 0.5};
  line.n = 60;
  line.fiber_angle_deg = 20;
  Material woven = line;
  woven.has_second_fiber = true;
  woven.second_angle_deg = 110;
  woven.second_weight = 0.6;
  Material iso = line;
  iso.has_isotropic = true;
  iso.iso_kd = {0.05, 0.05, 0.05};
  iso.iso_ks = {0.3, 0.3, 0.3};
  iso.iso_n = 40;
  Material iso_only = iso;
  iso_only.kd = iso_only.ks = {0, 0, 0};
  iso_only.iso_kd = {0.4, 0.3, 0.2};
  Material fiber = flat_silk(0.4, 40);
  fiber.has_second_fiber = true;
  fiber.second_angle_deg = 120;
  fiber.has_isotropic = true;
  fiber.iso_ks = {0.2, 0.2, 0.2};
  fiber.iso_n = 80;
  const std::pair<const char*, Material> cases[] = {
      {"line, second fiber", woven},
      {"line, isotropic term", iso},
      {"isotropic part alone", iso_only},
      {"fiber, second fiber and isotropic term", fiber}};
  for (const auto& [what, m] : cases)
    for (const Environment* env : {&studio, static_cast<const Environment*>(&uniform)}) {
      PreviewOptions p;
      p.width = p.height = m.fiber() ? 32 : 48;  // (the fiber model's brute force is the slow one)
      p.reference = true;
      p.environment = env;
      // And apart from the material without the term: the term is drawn.
      Material without = m;
      without.has_second_fiber = false;
      if (!m.second_active()) without.has_isotropic = false;
      PreviewResult r;
      const double apart = rendered_apart(m, without, p, &r);
      std::printf(
          "%s under %s: against brute force mean abs %.4g (mean %.4g), relative RMS %.4g, max "
          "%.4g; without the term %.0f %% of the image's sum apart\n",
          what, env->name.c_str(), r.env_mean_abs, r.env_reference_mean, r.env_rel_rms,
          r.max_abs_diff, 100 * apart);
      EXPECT_GT(r.env_reference_mean, 0.02) << what;
      EXPECT_LT(r.env_rel_rms, 0.05) << what << " under " << env->name;
      // (Under a uniform environment a second fiber's direction hardly shows.)
      if (env == &studio) {
        EXPECT_GT(apart, 0.03) << what;
      }
    }
}

// A line material with a map of n (woven-patch: warp n = 30, weft n = 12, with maps of k_d and
// the fiber direction) under the studio: S's terms at levels of n, blended at each fragment's
// log n, against brute force with the material at each fragment's uv, and apart from the same
// material at one n; and the same maps on the fiber model (S_line and F at the levels of n).
TEST(EnvironmentTerms, MapOfNAgainstBruteForce) {
  const Environment studio = studio_environment();
  PresetOptions po;
  po.views = 1;
  po.width = po.height = 16;
  po.progress = nullptr;
  const Material woven = make_preset("woven-patch", po).truth;
  ASSERT_TRUE(woven.maps.n);
  Material fiber = woven;
  fiber.model = Model::kFiber;
  fiber.topology = UniformS{0.3};
  // And n alternating 12 and 30 texel by texel: every fragment between two levels.
  Material checker = fiber;
  auto img = std::make_shared<Image>(*fiber.maps.n);
  for (size_t k = 0; k < img->px.size(); ++k) img->px[k] = (k + k / img->width) % 2 ? 30.f : 12.f;
  checker.maps.n = img;
  for (const Material& m : {woven, fiber, checker}) {
    PreviewOptions p;
    p.shape = "flat";
    p.width = p.height = m.fiber() ? 28 : 64;  // (the fiber model's brute force is the slow one)
    p.view_dir = {0.2, -0.5, 1};
    p.reference = true;
    p.environment = &studio;
    Material one_n = m;
    one_n.maps.n = nullptr;
    one_n.n = 20;
    PreviewResult r;
    const double apart = rendered_apart(m, one_n, p, &r);
    std::printf(
        "woven-patch's map of n (%s model) under the studio: prefiltered in %.2f s; against "
        "brute force mean abs %.4g (mean %.4g), relative RMS %.4g, max %.4g; at one n %.0f %% of "
        "the image's sum apart\n",
        m.fiber() ? "fiber" : "line", r.env_prefilter_seconds, r.env_mean_abs, r.env_reference_mean,
        r.env_rel_rms, r.max_abs_diff, 100 * apart);
    EXPECT_GT(r.env_reference_mean, 0.02);
    EXPECT_LT(r.env_rel_rms, 0.05);
    if (m.maps.n != checker.maps.n) {  // (the checker's n averages to about the one n)
      EXPECT_GT(apart, 0.03);
    }
  }
}

}  // namespace
}  // namespace aniso
