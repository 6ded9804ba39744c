// The 4-lane pass of the plain line model (fit/solvers/line_pixel_lanes.h) against the scalar pass
// it stands for (fit/solvers/line_pixel.h): its own exp and log, and the sums of a pass over pixels
// that reach every branch (the lobe's x <= 0, the chord near |a| = 1, Huber's outliers, a last
// group of fewer than four).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include "core/frame.h"
#include "fit/fit.h"
#include "fit/maps/texel_sigmas.h"
#include "fit/records/observations.h"
#include "fit/records/pixel_frames.h"
#include "fit/records/pixel_records.h"
#include "fit/solvers/line_pixel_lanes.h"
#include "fit/solvers/line_solve.h"
#include "fit/solvers/start.h"
#include "fit/solvers/texel_lanes.h"
#include "io/formats/capture.h"
#include "test_util.h"

namespace aniso::fitting {
namespace {

// The 4-lane pass's own exp and log against libm's over the range the lobe uses (x^n with x in
// (0, 1], n up to 10^4) and beyond: within 2 ulp.
TEST(FitPaths, VectorExpAndLogWithinTwoUlpOfLibm) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 and FMA on this CPU";
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  double worst_exp = 0, worst_log = 0;
  auto ulps = [](double a, double b) {
    return std::abs(a - b) / (std::nextafter(std::abs(b), INFINITY) - std::abs(b));
  };
  for (int i = 0; i < 200000; ++i) {
    double in[4], e[4], l[4];
    for (double& x : in)
      x = i % 2 ? -700 * u(rng) + 5 * u(rng) : std::pow(10.0, -300 * u(rng) + 8 * u(rng));
    if (i % 2 == 0) in[0] = 1 + (u(rng) - 0.5) * 1e-6;  // near 1, where log is smallest
    simd_exp_log(in, e, l);
    for (int k = 0; k < 4; ++k) {
      if (i % 2)
        worst_exp = std::max(worst_exp, ulps(e[k], std::exp(in[k])));
      else
        worst_log = std::max(worst_log, ulps(l[k], std::log(in[k])));
    }
  }
  std::printf("vector exp: worst %.2f ulp; vector log: worst %.2f ulp\n", worst_exp, worst_log);
  EXPECT_LE(worst_exp, 2.0);
  EXPECT_LE(worst_log, 2.0);
  double in[4] = {-709, -1e4, 0, 1}, e[4], l[4];
  simd_exp_log(in, e, l);
  EXPECT_EQ(e[0], 0.0);
  EXPECT_EQ(e[1], 0.0);
  EXPECT_EQ(e[2], 1.0);
  EXPECT_EQ(l[3], 0.0);
}

// The sums of one chunk, four lanes at a time against one pixel at a time: the same to rounding
// (1e-11 relative). With views a hair from the fiber (|b| = 1 - 1e-13, the chord of
// models/safe_math.h) x = 1 - b^2 cancels to 1e-13, where the lanes' fused multiply-add and the
// scalar pass round differently in x's fourth digit: 1e-9 there.
// 1001 random pixels with `lights` lights each; with `chord`, every 7th view at |b| ~ 1.
ObsSet random_set(bool chord, int lights) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  ObsSet os;
  auto dir = [&](double up) {
    LocalDir d{u(rng), u(rng), 0};
    d.n = std::sqrt(std::max(0.0, 1 - d.u * d.u - d.w * d.w)) + up;
    return d;
  };
  for (int i = 0; i < 1001; ++i) {
    Observation o;
    o.V = dir(0);
    if (chord && i % 7 == 0)
      o.V = LocalDir{std::cos(0.5), std::sin(0.5) * (1 - 1e-13), 1e-7};  // |b| ~ 1
    o.first_light = static_cast<uint32_t>(os.lights.size());
    o.num_lights = lights;
    for (int k = 0; k < 3; ++k) o.y[k] = static_cast<float>(0.3 + 0.2 * u(rng) + (i % 50 == 0));
    for (int j = 0; j < lights; ++j) {
      ObsLight l;
      l.L = dir(0.01);
      for (int k = 0; k < 3; ++k) l.E[k] = static_cast<float>(1 + 0.1 * k);
      os.lights.push_back(l);
    }
    os.obs.push_back(o);
  }
  return os;
}

void compare_passes(bool chord) {
  ObsSet os = random_set(chord, 1);
  const double kd[3] = {0.2, 0.3, 0.1}, ks[3] = {0.5, 0.4, 0.6};
  const double psi = 0.5;
  for (double n : {1.0, 40.0, 5000.0})
    for (FitLoss kind : {FitLoss::kNone, FitLoss::kHuber}) {
      const LinePixelParams p{kd, ks, n, std::cos(psi), std::sin(psi)};
      const RobustLoss loss{kind, 0.1};
      ChannelSums<8> lanes, scalar;
      HuberCurvature<8> lanes_c, scalar_c;
      os.simd = true;
      line_chunk(os, nullptr, 0, os.obs.size(), p, loss, true, &lanes, &lanes_c);
      os.simd = false;
      line_chunk(os, nullptr, 0, os.obs.size(), p, loss, true, &scalar, &scalar_c);
      auto near = [&](double a, double b) {
        EXPECT_NEAR(a, b, (chord ? 1e-9 : 1e-11) * (1 + std::abs(b)))
            << "n " << n << ", loss " << int(kind) << (chord ? ", chord" : "");
      };
      near(lanes.cost, scalar.cost);
      near(lanes.rss, scalar.rss);
      for (int k = 0; k < 3; ++k) {
        for (int t = 0; t < 10; ++t) near(lanes.h[k][t], scalar.h[k][t]);
        for (int a = 0; a < 4; ++a) near(lanes.g[k][a], scalar.g[k][a]);
      }
      // Huber's curvature outside its core (fit/solvers/fused_lm.h), present only under Huber.
      double sum = 0;
      for (int t = 0; t < HuberCurvature<8>::kTri; ++t) {
        near(lanes_c.c[t], scalar_c.c[t]);
        sum += std::abs(scalar_c.c[t]);
      }
      if (kind == FitLoss::kHuber)
        EXPECT_GT(sum, 0) << "no observation outside the core at n " << n;
      else
        EXPECT_EQ(sum, 0);
    }
}

TEST(FitPaths, FourLanePassSumsAsTheScalarPass) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 and FMA on this CPU";
  compare_passes(false);
  compare_passes(true);
}

// The start's nodes (fit/solvers/start.h) four psi at a time against one at a time: the same k_d,
// k_s and cost to rounding, with one and three lights per pixel, n from 2 to 4096, six nodes (four
// in lanes, two alone).
TEST(FitPaths, FourStartNodesAtOnceAsOneByOne) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 and FMA on this CPU";
  for (int lights : {1, 3}) {
    ObsSet os = random_set(false, lights);
    std::vector<size_t> idx;
    for (size_t i = 0; i < os.obs.size(); i += 2) idx.push_back(i);
    const double psi[6] = {0, 0.3, 1.2, 2.0, 2.9, 3.1};
    for (int log2n : {1, 5, 12}) {
      NodeFit lanes[6], alone[6];
      os.simd = true;
      line_nodes_cost(os, idx, psi, 6, log2n, lanes);
      os.simd = false;
      line_nodes_cost(os, idx, psi, 6, log2n, alone);
      for (int k = 0; k < 6; ++k) {
        EXPECT_NEAR(lanes[k].cost, alone[k].cost, 1e-11 * alone[k].cost) << log2n << " " << k;
        for (int ch = 0; ch < 3; ++ch) {
          EXPECT_NEAR(lanes[k].kd[ch], alone[k].kd[ch], 1e-10 * (1e-3 + alone[k].kd[ch]));
          EXPECT_NEAR(lanes[k].ks[ch], alone[k].ks[ch], 1e-10 * (1e-3 + alone[k].ks[ch]));
        }
      }
    }
  }
}

// Eight nodes' closed-form k_d, k_s at once (solve_kd_ks8) against KdKsSums::solve node by node:
// the same bits, over sums that take every branch (both columns, k_d or k_s alone, a negative
// unconstrained solution, a singular 2x2, empty columns).
TEST(FitPaths, EightNodesClosedFormAsOneByOne) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  int both = 0, kd_only = 0, ks_only = 0, none = 0;
  for (int it = 0; it < 4000; ++it) {
    KdKsSums sums[8];
    for (int k = 0; k < 8; ++k)
      for (int ch = 0; ch < 3; ++ch) {
        KdKsSums& s = sums[k];
        const double d = 1 + u(rng), e = u(rng), f = 1 + u(rng);
        s.dd[ch] = d * d, s.ds[ch] = d * f * e, s.ss[ch] = f * f;
        s.dy[ch] = u(rng), s.sy[ch] = u(rng);
        s.yy[ch] = s.dy[ch] * s.dy[ch] + s.sy[ch] * s.sy[ch] + 2 + u(rng);
        const int kind = (it + 3 * k + ch) % 9;
        if (kind == 1) s.ds[ch] = std::sqrt(s.dd[ch] * s.ss[ch]);  // singular
        if (kind == 2) s.dd[ch] = s.ds[ch] = s.dy[ch] = 0;         // no diffuse column
        if (kind == 3) s.ss[ch] = s.ds[ch] = s.sy[ch] = 0;         // no specular column
        if (kind == 4) s = KdKsSums{};                             // nothing at all
      }
    NodeFit lanes[8];
    solve_kd_ks8(sums, lanes);
    for (int k = 0; k < 8; ++k) {
      double kd[3], ks[3];
      const double cost = sums[k].solve(kd, ks);
      ASSERT_TRUE(same(lanes[k].cost, cost))
          << it << " " << k << ": " << lanes[k].cost << " " << cost;
      for (int ch = 0; ch < 3; ++ch) {
        ASSERT_TRUE(same(lanes[k].kd[ch], kd[ch]) && same(lanes[k].ks[ch], ks[ch])) << it;
        (kd[ch] > 0 && ks[ch] > 0 ? both : kd[ch] > 0 ? kd_only : ks[ch] > 0 ? ks_only : none)++;
      }
    }
  }
  std::printf("k_d and k_s %d, k_d alone %d, k_s alone %d, neither %d: bit for bit\n", both,
              kd_only, ks_only, none);
  EXPECT_GT(std::min({both, kd_only, ks_only, none}), 1000);
}

// The start's grid over (psi, n) four columns at a time against one: the same node, k_d, k_s
// and n on a set with one and three lights per pixel.
TEST(FitPaths, FourGridColumnsAtOnceAsOneByOne) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 and FMA on this CPU";
  for (int lights : {1, 3}) {
    ObsSet os = random_set(false, lights);
    Core lanes, alone;
    const std::string a = line_grid_start(os, &lanes);
    os.simd = false;
    const std::string b = line_grid_start(os, &alone);
    EXPECT_EQ(a, b);
    EXPECT_EQ(lanes.psi, alone.psi);
    EXPECT_EQ(lanes.logn, alone.logn);
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR(lanes.kd[ch], alone.kd[ch], 1e-10 * (1e-3 + alone.kd[ch]));
      EXPECT_NEAR(lanes.ks[ch], alone.ks[ch], 1e-10 * (1e-3 + alone.ks[ch]));
    }
  }
}

}  // namespace
}  // namespace aniso::fitting

namespace aniso::fitting {
namespace {

// Every third observation, less the last `drop`; *groups: the lanes' groups.
void texel_lanes_as_the_double_pass(const ObsSet& os, size_t drop, bool wide, size_t* groups) {
  std::vector<size_t> idx;
  for (size_t i = 0; i < os.obs.size(); i += 3) idx.push_back(i);
  idx.resize(idx.size() - drop);
  TexelLanes lanes;
  ASSERT_TRUE(texel_lanes(os, idx, &lanes, wide));
  EXPECT_EQ(lanes.count, idx.size());
  *groups = lanes.groups;
  const double kd[3] = {0.2, 0.3, 0.1}, ks[3] = {0.5, 0.4, 0.6};
  for (double n : {1.0, 40.0, 2000.0}) {
    const LinePixelParams p{kd, ks, n, std::cos(0.5), std::sin(0.5)};
    ChannelSums<8> ref, f32, f64;
    line_chunk(os, idx.data(), 0, idx.size(), p, RobustLoss{FitLoss::kNone, 0}, true, &ref);
    texel_pass_f32(lanes, p, true, &f32);
    line_pass_lanes(lanes, p, true, &f64);
    double scale = 0;
    for (int k = 0; k < 3; ++k)
      for (int t = 0; t < 10; ++t) scale = std::max(scale, std::abs(ref.h[k][t]));
    EXPECT_NEAR(f32.cost, ref.cost, 1e-4 * ref.cost) << n;
    EXPECT_NEAR(f64.cost, ref.cost, 1e-6 * ref.cost) << n;
    for (int k = 0; k < 3; ++k) {
      for (int t = 0; t < 10; ++t) {
        EXPECT_NEAR(f32.h[k][t], ref.h[k][t], 1e-4 * scale) << n << " h " << k << " " << t;
        EXPECT_NEAR(f64.h[k][t], ref.h[k][t], 1e-6 * scale) << n << " h " << k << " " << t;
      }
      for (int a = 0; a < 4; ++a) {
        EXPECT_NEAR(f32.g[k][a], ref.g[k][a], 1e-4 * scale) << n << " g " << k << " " << a;
        EXPECT_NEAR(f64.g[k][a], ref.g[k][a], 1e-6 * scale) << n << " g " << k << " " << a;
      }
    }
  }
  const double psi[8] = {0, 0.3, 0.7, 1.2, 1.6, 2.0, 2.5, 2.9};
  for (int log2n : {1, 5, 12}) {
    NodeFit ref[8];
    line_nodes_cost(os, idx, psi, 8, log2n, ref);
    KdKsSums sums[8];
    texel_nodes_f32(lanes, psi, log2n, sums);
    int best_ref = 0, best_f32 = 0;
    double cost[8];
    for (int k = 0; k < 8; ++k) {
      double kdk[3], ksk[3];
      cost[k] = sums[k].solve(kdk, ksk);
      EXPECT_NEAR(cost[k], ref[k].cost, 1e-4 * ref[k].cost) << log2n << " node " << k;
      if (ref[k].cost < ref[best_ref].cost) best_ref = k;
      if (cost[k] < cost[best_f32]) best_f32 = k;
    }
    EXPECT_EQ(best_f32, best_ref) << log2n;
  }
}

// The texel tests below run once per lane width this CPU has: eight (AVX2), and sixteen
// (AVX-512) where it has them.
struct TexelWidths {
  std::vector<bool> wide{false};
  TexelWidths() {
    if (texel_avx512_available()) wide.push_back(true);
  }
};

// A texel's float lanes (fit/solvers/texel_lanes.h) against the double pass over the same records:
// the cost, J^T J and J^T r to float's rounding (relative 1e-4 of each sum's scale), the double
// pass from the lanes to double's, and eight start nodes at once as the double nodes (same cost to
// 1e-4, the same best node); at either lane width, with an even and an odd number of groups.
TEST(FitPaths, TexelFloatLanesAsTheDoublePass) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 and FMA on this CPU";
  const ObsSet os = random_set(false, 1);
  const TexelWidths widths;
  size_t groups[2] = {0, 0};
  for (const bool wide : widths.wide)
    for (const size_t drop : {0, 8}) {  // an even and an odd number of groups
      SCOPED_TRACE(wide ? "sixteen lanes" : "eight lanes");
      SCOPED_TRACE("less " + std::to_string(drop) + " observations");
      texel_lanes_as_the_double_pass(os, drop, wide, &groups[drop > 0]);
    }
  EXPECT_NE(groups[0] % 2, groups[1] % 2);
}

void grey_lights_as_three_channels(size_t count, bool wide);

// Under grey lights the start nodes share the channels' dd, ds, ss sums: the same numbers, bit for
// bit, as the three channels summed apart (the lanes told their lights are not grey); the pass's
// J^T J and J^T r come from products shared by the channels, as the double pass's to float's
// rounding; a coloured light anywhere in the texel keeps the channels apart. At either lane width,
// with 77 observations (10 groups) and 67 (9: the sixteen lanes' last group half padding).
TEST(FitPaths, TexelGreyLightsAsThreeChannels) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 and FMA on this CPU";
  const TexelWidths widths;
  for (const bool wide : widths.wide)
    for (const size_t count : {77, 67}) {  // not a whole number of groups or blocks
      SCOPED_TRACE(wide ? "sixteen lanes" : "eight lanes");
      SCOPED_TRACE(std::to_string(count) + " observations");
      grey_lights_as_three_channels(count, wide);
    }
}

void grey_lights_as_three_channels(size_t count, bool wide) {
  ObsSet os = random_set(false, 1);
  for (ObsLight& l : os.lights) l.E[1] = l.E[2] = l.E[0];
  std::vector<size_t> idx;
  for (size_t i = 0; i < count; ++i) idx.push_back(i);
  TexelLanes grey;
  ASSERT_TRUE(texel_lanes(os, idx, &grey, wide));
  ASSERT_TRUE(grey.grey_light);
  TexelLanes apart = grey;
  apart.grey_light = false;
  const double psi[8] = {0, 0.3, 0.7, 1.2, 1.6, 2.0, 2.5, 2.9};
  KdKsSums a[8], b[8];
  texel_nodes_f32(grey, psi, 4, a);
  texel_nodes_f32(apart, psi, 4, b);
  for (int k = 0; k < 8; ++k)
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_EQ(a[k].dd[ch], b[k].dd[ch]) << k << " " << ch;
      EXPECT_EQ(a[k].ds[ch], b[k].ds[ch]) << k << " " << ch;
      EXPECT_EQ(a[k].ss[ch], b[k].ss[ch]) << k << " " << ch;
      EXPECT_EQ(a[k].dy[ch], b[k].dy[ch]) << k << " " << ch;
      EXPECT_EQ(a[k].sy[ch], b[k].sy[ch]) << k << " " << ch;
    }
  // The pass's J^T J and J^T r from the products shared by the channels, against the double pass
  // over the same records (as FitPaths.TexelFloatLanesAsTheDoublePass for coloured lights).
  const double kd[3] = {0.2, 0.3, 0.1}, ks[3] = {0.5, 0.4, 0.6};
  for (double n : {1.0, 40.0, 2000.0}) {
    const LinePixelParams p{kd, ks, n, std::cos(0.5), std::sin(0.5)};
    ChannelSums<8> ref, f32, sep;
    line_chunk(os, idx.data(), 0, idx.size(), p, RobustLoss{FitLoss::kNone, 0}, true, &ref);
    texel_pass_f32(grey, p, true, &f32);
    texel_pass_f32(apart, p, true, &sep);
    double scale = 0;
    for (int k = 0; k < 3; ++k)
      for (int t = 0; t < 10; ++t) scale = std::max(scale, std::abs(ref.h[k][t]));
    EXPECT_EQ(f32.cost, sep.cost) << n;  // the residuals are the same arithmetic
    EXPECT_NEAR(f32.cost, ref.cost, 1e-4 * ref.cost) << n;
    for (int k = 0; k < 3; ++k) {
      for (int t = 0; t < 10; ++t)
        EXPECT_NEAR(f32.h[k][t], ref.h[k][t], 1e-4 * scale) << n << " h " << k << " " << t;
      for (int a = 0; a < 4; ++a)
        EXPECT_NEAR(f32.g[k][a], ref.g[k][a], 1e-4 * scale) << n << " g " << k << " " << a;
    }
  }
  os.lights[os.obs[idx[40]].first_light].E[2] *= 1.5f;
  TexelLanes coloured;
  ASSERT_TRUE(texel_lanes(os, idx, &coloured, wide));
  EXPECT_FALSE(coloured.grey_light);
}

// The texel's block solve (fit/maps/texel_sigmas.h) against Eigen's dense inverse, on J^T J of rows
// shaped as a texel's (channel k's row nonzero at k_d[k], k_s[k], log n, psi) plus a diagonal, as
// the LM's damping adds: the step and the inverse's diagonal to 1e-6 relative, over matrices from
// well to badly conditioned; a matrix that is not positive definite is refused.
TEST(FitPaths, TexelBlockSolveAsTheDenseInverse) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0, 1);
  double worst = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Mat8 H = Mat8::Zero();
    const double tilt = std::pow(10.0, -4.0 * (trial % 5) / 4);  // k_s's column nearly k_d's
    for (int row = 0; row < 60; ++row) {
      const int k = row % 3;
      Vec8 j = Vec8::Zero();
      j(k) = g(rng);
      j(3 + k) = j(k) + tilt * g(rng);
      j(6) = g(rng), j(7) = 3 * g(rng);
      H += j * j.transpose();
    }
    H.diagonal() += 1e-3 * (trial % 2) * H.diagonal();
    Vec8 b;
    for (int k = 0; k < 8; ++k) b(k) = g(rng);
    TexelBlocks f;
    ASSERT_TRUE(f.factor(H)) << "trial " << trial;
    const Mat8 inv = H.inverse();
    const Vec8 x = f.solve(b), want = inv * b, d = f.inverse_diagonal();
    worst = std::max(worst, (x - want).norm() / want.norm());
    for (int k = 0; k < 8; ++k) worst = std::max(worst, std::abs(d(k) / inv(k, k) - 1));
  }
  EXPECT_LT(worst, 1e-6);  // both carry rounding of up to cond x 1e-16 (cond up to ~1e9 here)
  Mat8 bad = Mat8::Identity();
  bad(6, 7) = bad(7, 6) = 2;  // indefinite shared block
  TexelBlocks f;
  EXPECT_FALSE(f.factor(bad));
  bad = Mat8::Identity();
  bad(1, 4) = bad(4, 1) = 1;  // a singular channel block
  EXPECT_FALSE(f.factor(bad));
  std::printf("block solve against the dense inverse: worst relative difference %.2e\n", worst);
}

// The loader's four pixels at a time (fit/records/pixel_frames.h) against make_frame, to_local and
// light_at one pixel at a time: the same bits, over random buffers with the cases that branch (a
// zero normal, a tangent along the normal, the light on the point, an attenuation that is 0).
TEST(FitPaths, PixelQuadsAreTheScalarFramesBitForBit) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 on this CPU";
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<float> u(-1, 1);
  auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  size_t checked = 0, frames = 0, lit = 0;
  for (int it = 0; it < 20000; ++it) {
    const Vec3 eye(3 * u(rng), 3 * u(rng), 4 + u(rng));
    Light light;
    light.position = Vec3(2 * u(rng), 2 * u(rng), 2 + u(rng));
    light.attenuation = {it % 5 == 0 ? 0.0 : 0.5 + u(rng), it % 3 == 0 ? 0.0 : 0.3, 1.0};
    if (it % 17 == 0) light.attenuation = {0, 0, 0};  // att = 0: reaches nothing
    PixelQuad q;
    Vec3 P[4], N[4], U[4];
    for (int l = 0; l < 4; ++l) {
      P[l] = Vec3(u(rng), u(rng), 0.1f * u(rng));
      N[l] = Vec3(0.2f * u(rng), 0.2f * u(rng), 1.0f + 0.1f * u(rng));
      U[l] = Vec3(1.0f + 0.1f * u(rng), 0.3f * u(rng), 0.1f * u(rng));
      if (it % 7 == 0 && l == 1) N[l] = Vec3(0, 0, 0);
      if (it % 11 == 0 && l == 2) U[l] = N[l] * 2.0;
      if (it % 13 == 0 && l == 3) P[l] = light.position, light.attenuation = {1.0, 0, 0};
      for (int c = 0; c < 3; ++c) q.P[c][l] = P[l][c], q.N[c][l] = N[l][c], q.U[c][l] = U[l][c];
    }
    pixel_quad(eye, light, &q);
    for (int l = 0; l < 4; ++l, ++checked) {
      SurfacePoint sp;
      const bool ok = make_frame(P[l], N[l], U[l], &sp);
      ASSERT_EQ(q.frame_ok[l], ok) << it << " lane " << l;
      if (!ok) continue;
      ++frames;
      const LocalDir V = to_local(sp, normalize(eye - sp.P));
      EXPECT_TRUE(same(q.V[l].u, V.u) && same(q.V[l].w, V.w) && same(q.V[l].n, V.n)) << it;
      Vec3 L;
      RGB E;
      double dist;
      const bool reaches = light_at(light, sp.P, &L, &E, &dist);
      const bool quad_reaches = q.lit[l] && light.intensity[0] * q.f[l] > 0;
      ASSERT_EQ(quad_reaches, reaches) << it << " lane " << l;
      if (!reaches) continue;
      ++lit;
      const LocalDir Ll = to_local(sp, L);
      EXPECT_TRUE(same(q.L[l].u, Ll.u) && same(q.L[l].w, Ll.w) && same(q.L[l].n, Ll.n)) << it;
      EXPECT_TRUE(same(light.intensity[0] * q.f[l], E[0])) << it;
    }
  }
  std::printf("%zu pixels: %zu frames, %zu lit, bit for bit\n", checked, frames, lit);
  EXPECT_GT(lit, checked / 2);
  EXPECT_LT(frames, checked);
}

// Views that share a geometry and an eye (a fixed camera) share their pixels' texels, frames and V
// (fit/records/pixel_records.h SharedPixels): their records against each view finding its own, bit
// for bit, with saturated pixels left out, a view whose eye moved (its own frames), --subsample and
// --maps' texels; and band by band, the same maps.
TEST(FitPaths, ViewsSharingAGeometryGiveTheRecordsOfEachViewAlone) {
  if (!line_lanes_on(true)) GTEST_SKIP() << "no AVX2 on this CPU";
  const std::string dir = test::tmp_dir("shared_pixels");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 96x80 --views 6");
  ASSERT_EQ(r.status, 0) << r.output;
  test::edit_json(dir + "/set/capture.json", [](auto& j) {
    j["color"]["saturation"] = 0.35;                  // some pixels of every view left out
    j["views"][4]["world_from_camera"][0][3] = 1e-3;  // an eye of its own
  });
  const CaptureSet set = read_capture(dir + "/set");
  auto bytes = [](const auto& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0]));
  };
  // Each stride with the shared light in eight lanes of AVX-512 (where the CPU has it) and in two
  // of four of AVX2.
  for (const int stride : {1, 2, -1, -2}) {
    SCOPED_TRACE(stride > 0 ? "AVX-512 where the CPU has it" : "AVX2");
    FitOptions opt;
    opt.subsample = std::abs(stride);
    opt.maps_w = 24, opt.maps_h = 20;
    opt.progress = nullptr;
    FitReport shared_rep, alone_rep;
    opt.line_lanes.avx512 = stride > 0;
    const ObsSet shared = capture_observations(set, opt, &shared_rep);
    opt.line_lanes.shared_pixels = false;
    const ObsSet alone = capture_observations(set, opt, &alone_rep);
    ASSERT_GT(shared.obs.size(), 1000u);
    EXPECT_GT(shared_rep.saturated, 100u);
    EXPECT_TRUE(bytes(shared.obs) == bytes(alone.obs)) << "stride " << stride;
    EXPECT_TRUE(bytes(shared.lights) == bytes(alone.lights)) << "stride " << stride;
    EXPECT_TRUE(bytes(shared.texel) == bytes(alone.texel)) << "stride " << stride;
    EXPECT_EQ(shared_rep.pixels, alone_rep.pixels);
    EXPECT_EQ(shared_rep.saturated, alone_rep.saturated);
    EXPECT_EQ(shared_rep.nonfinite, alone_rep.nonfinite);
    EXPECT_EQ(shared_rep.unlit, alone_rep.unlit);
  }
  // With --global the maps load band by band, each band's pixels shared: the same maps, bit for
  // bit.
  FitOptions g;
  g.progress = nullptr;
  g.keep_anisotropic = true;  // a global fit for --global, as docs/maps.md asks
  g.subsample = 2;
  const FitResult global = fit_capture(set, g);
  FitOptions opt;
  opt.progress = nullptr;
  opt.maps_w = 24, opt.maps_h = 20;
  opt.maps_memory_mb = 0.05;  // several bands
  opt.global = given_global(fit_text(global), "global", set.dir);
  const FitResult shared = fit_capture(set, opt);
  opt.line_lanes.shared_pixels = false;
  const FitResult alone = fit_capture(set, opt);
  opt.line_lanes.shared_pixels = true;
  EXPECT_GT(shared.report.maps_bands, 2u);
  EXPECT_GT(shared.maps.fitted, 300u);
  for (const auto& arr : kTexelArrays)
    EXPECT_TRUE(bytes(shared.maps.*arr.d) == bytes(alone.maps.*arr.d)) << arr.key;
  EXPECT_EQ(shared.maps.pixels, alone.maps.pixels);
  EXPECT_EQ(shared.report.pixels, alone.report.pixels);
  // Records that fit one band, but more shared pixels than a band may hold (fit/fit.h
  // kMapsSharedBandBytes, lowered here): bands of rows whose shared pixels stay within it, the
  // same maps as one band.
  opt.maps_memory_mb = 512;
  const FitResult one = fit_capture(set, opt);
  EXPECT_EQ(one.report.maps_bands, 1);
  ASSERT_GT(one.report.maps_band_shared_bytes, 4000u);
  opt.maps_shared_band_bytes = static_cast<double>(one.report.maps_band_shared_bytes) / 4;
  const FitResult capped = fit_capture(set, opt);
  EXPECT_GE(capped.report.maps_bands, 4);
  EXPECT_LE(capped.report.maps_band_shared_bytes, opt.maps_shared_band_bytes);
  for (const auto& arr : kTexelArrays)
    EXPECT_TRUE(bytes(capped.maps.*arr.d) == bytes(one.maps.*arr.d)) << arr.key;
  EXPECT_EQ(capped.maps.pixels, one.maps.pixels);
  EXPECT_EQ(capped.report.pixels, one.report.pixels);
}

// A plain --maps fit past --maps-memory fits its global values first on a --subsample: the one
// its records fit in, or a coarser one where that still holds more than maps_global_pixels
// (fit/fit.h kMapsGlobalPixels, lowered here), as does one within --maps-memory but past those
// pixels; the maps those of that global fit run by hand.
TEST(FitMaps, APlainMapsFitTakesAtMostItsGlobalPixels) {
  const std::string dir = test::tmp_dir("global_pixels");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 96x80 --views 6");
  ASSERT_EQ(r.status, 0) << r.output;
  const CaptureSet set = read_capture(dir + "/set");
  FitOptions opt;
  opt.progress = nullptr;
  opt.maps_w = 24, opt.maps_h = 20;
  opt.maps_memory_mb = 0.3;
  opt.maps_global_pixels = 1e12;  // the records' budget alone
  const FitResult by_memory = fit_capture(set, opt);
  const int k0 = by_memory.report.global_subsample;
  ASSERT_GE(k0, 2);
  opt.maps_global_pixels = static_cast<double>(by_memory.report.pixels) / 40;
  const FitResult capped = fit_capture(set, opt);
  const int k = capped.report.global_subsample;
  std::printf(
      "%zu pixels: the global fit on 1 in %d by the records' budget, 1 in %d by at most "
      "%.0f pixels\n",
      by_memory.report.pixels, k0, k, opt.maps_global_pixels);
  EXPECT_GE(k, 7);  // sqrt(40) = 6.3
  FitOptions g;
  g.progress = nullptr;
  g.keep_anisotropic = true;  // a global fit for --global, as docs/maps.md asks
  g.subsample = k;
  // As a --maps fit's own global fit: the line model's psi (the highlight's symmetry is a global
  // fit's alone; where the swirl's misfit asks for it, it may be taken).
  g.psi_symmetry = PsiSymmetry::kNever;
  const FitResult global = fit_capture(set, g);
  EXPECT_LE(static_cast<double>(global.report.pixels), opt.maps_global_pixels);
  EXPECT_EQ(global.material.kd, capped.material.kd);
  FitOptions by_hand = opt;
  by_hand.global = given_global(fit_text(global), "global", set.dir);
  const FitResult two_steps = fit_capture(set, by_hand);
  auto bytes = [](const auto& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0]));
  };
  ASSERT_GT(capped.maps.fitted, 300u);
  for (const auto& arr : kTexelArrays)
    EXPECT_TRUE(bytes(capped.maps.*arr.d) == bytes(two_steps.maps.*arr.d)) << arr.key;
  // Records within --maps-memory: the global fit on every pixel where they are few enough, on
  // the same subsample where they are not.
  opt.maps_memory_mb = 512;
  const double few = opt.maps_global_pixels;
  opt.maps_global_pixels = 1e12;
  EXPECT_EQ(fit_capture(set, opt).report.global_subsample, 0);
  opt.maps_global_pixels = few;
  const FitResult within = fit_capture(set, opt);
  EXPECT_EQ(within.report.global_subsample, k);
  for (const auto& arr : kTexelArrays)
    EXPECT_TRUE(bytes(within.maps.*arr.d) == bytes(two_steps.maps.*arr.d)) << arr.key;
}

// A --global that was itself a --maps fit: its warnings about its global values come along, those
// about its own maps do not (this fit says its own): each warning once.
TEST(FitMaps, AGlobalFromAMapsFitLeavesItsMapsWarningsBehind) {
  const std::string dir = test::tmp_dir("global_warnings");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 96x80 --views 6");
  ASSERT_EQ(r.status, 0) << r.output;
  auto warnings = [](const std::string& out) {
    std::vector<std::string> w;
    std::istringstream in(out);
    for (std::string line; std::getline(in, line);)
      if (line.rfind("fit: WARNING: ", 0) == 0) w.push_back(line.substr(14));
    return w;
  };
  auto maps = [](const std::vector<std::string>& w) {
    return std::count_if(w.begin(), w.end(),
                         [](const std::string& s) { return s.rfind("--maps", 0) == 0; });
  };
  r = test::run_cli("fit " + dir + "/set --maps 24x20 --out " + dir + "/first.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto first = warnings(r.output);
  ASSERT_GE(maps(first), 1) << r.output;
  ASSERT_GT(first.size(), static_cast<size_t>(maps(first))) << r.output;  // the global's own
  r = test::run_cli("fit " + dir + "/set --maps 24x20 --global " + dir + "/first.json --out " +
                    dir + "/second.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto second = warnings(r.output);
  EXPECT_EQ(maps(second), maps(first)) << r.output;
  std::set<std::string> seen;
  for (const std::string& w : second) EXPECT_TRUE(seen.insert(w).second) << "twice: " << w;
  for (const std::string& w : first) {
    if (w.rfind("--maps", 0) != 0) {
      EXPECT_TRUE(seen.count(w)) << "not carried: " << w;
    }
  }
}

}  // namespace
}  // namespace aniso::fitting
