// The fiber model (docs/models.md §4): the five identities, the fast evaluation against an
// independent brute-force reference over random and adversarial directions, finiteness, Jet
// derivatives.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <chrono>
#include <random>

#include "models/fiber_model.h"
#include "models/fiber_reference.h"
#include "models/line_model.h"

namespace aniso {
namespace {

struct Dirs {
  double lb, ln, vb, vn, a, b;
};

// Unit L and V (upper hemisphere) in the fiber frame (T, B, N).
Dirs random_dirs(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  auto unit = [&]() {
    double x = g(rng), y = g(rng), z = std::abs(g(rng));
    const double l = std::sqrt(x * x + y * y + z * z);
    return std::array<double, 3>{x / l, y / l, z / l};
  };
  const auto L = unit(), V = unit();
  return {L[1], L[2], V[1], V[2], L[0], V[0]};
}

// Adversarial: grazing view and light, L = V, L almost along T, L and V on opposite sides.
std::vector<Dirs> adversarial() {
  std::vector<Dirs> out;
  auto mk = [](double ta, double pa, double tb, double pb) {
    // theta from N, phi from T toward B.
    const double a = std::sin(ta) * std::cos(pa), lb = std::sin(ta) * std::sin(pa),
                 ln = std::cos(ta);
    const double b = std::sin(tb) * std::cos(pb), vb = std::sin(tb) * std::sin(pb),
                 vn = std::cos(tb);
    return Dirs{lb, ln, vb, vn, a, b};
  };
  const double d = M_PI / 180;
  for (double tl : {1.0, 45.0, 80.0, 88.0, 89.5})
    for (double tv : {1.0, 30.0, 85.0, 89.0})
      for (double pl : {0.0, 5.0, 90.0, 170.0})
        for (double pv : {0.0, 90.0, 180.0, 270.0})
          out.push_back(mk(tl * d, pl * d, tv * d, pv * d));
  out.push_back(mk(40 * d, 90 * d, 40 * d, 90 * d));   // L = V
  out.push_back(mk(89.9 * d, 0.5 * d, 20 * d, 0));     // L nearly along T
  out.push_back(mk(60 * d, 90 * d, 60 * d, 270 * d));  // mirror pair across N in the plane
  return out;
}

// sin_cos of a Jet is its own sin and cos, bit for bit (values and derivatives), over angles of
// every size and sign: the quadrature's one call where it made two.
TEST(FiberModel, SinCosOfAJetIsItsSinAndCos) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  using J = ceres::Jet<double, 3>;
  for (int k = 0; k < 10000; ++k) {
    J x(u(rng) * std::pow(10.0, 3 * u(rng)), 0);
    for (int i = 0; i < 3; ++i) x.v[i] = u(rng);
    J s, c;
    sin_cos(x, &s, &c);
    const J s0 = sin(x), c0 = cos(x);
    ASSERT_EQ(s.a, s0.a);
    ASSERT_EQ(c.a, c0.a);
    for (int i = 0; i < 3; ++i) {
      ASSERT_EQ(s.v[i], s0.v[i]) << x.a;
      ASSERT_EQ(c.v[i], c0.v[i]) << x.a;
    }
  }
}

// The lobe's nodes in SIMD lanes (models/fiber_lobe_simd.h: polynomial sin, cos, exp and log)
// against the scalar nodes (libm), for a double and the fused solver's Jet of three: values and
// derivatives within a few units in the last place of the largest, over random and adversarial
// directions, lobes from n = 1 to 1e4, every quadrature order the fits choose, absolute and
// relative to the peak. A polynomial off by one coefficient, or a lane whose mask is wrong, moves
// S by far more.
TEST(FiberModel, LobeInLanesIsTheScalarLobe) {
  if (fiber_detail::lobe_lanes() == 0) GTEST_SKIP() << "no AVX2 and FMA";
  using J = ceres::Jet<double, 3>;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Dirs> dirs = adversarial();
  for (int i = 0; i < 500; ++i) dirs.push_back(random_dirs(rng));  // (a minute under ASan at 1 500)
  double worst = 0, worst_jet = 0;
  size_t lit = 0;
  // Both widths where the CPU has AVX-512 (what a CPU with AVX2 alone runs, too).
  const std::vector<bool> widths =
      fiber_detail::lobe_lanes() == 8 ? std::vector<bool>{true, false} : std::vector<bool>{true};
  for (bool avx512 : widths)
    for (const Dirs& d : dirs)
      for (double n : {1.0, 7.5, 60.0, 900.0, 1e4})
        for (int order : {3, 4, 6, 8, 12, 16})
          for (bool rel : {false, true}) {
            const double s = u(rng);
            FiberAccuracy acc{order};
            double D[2], S[2], W;
            J Dj[2], Sj[2], Wj;
            const J nj(n, 0), sj(s, 2), psi(0.3, 1);
            // The directions as functions of psi (a rotation of T and B about N), so that every
            // derivative is exercised.
            const J c = cos(psi - 0.3), sn = sin(psi - 0.3);
            const J a = c * d.a + sn * d.lb, lb = c * d.lb - sn * d.a;
            const J b = c * d.b + sn * d.vb, vb = c * d.vb - sn * d.b;
            for (int k = 0; k < 2; ++k) {
              acc.lanes = k == 1 ? 0 : avx512 ? -1 : 4;
              fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, n, s, acc, &D[k], &S[k], &W, rel);
              fiber_DS(lb, J(d.ln), vb, J(d.vn), a, b, nj, sj, acc, &Dj[k], &Sj[k], &Wj, rel);
            }
            lit += S[1] > 0;
            // Within 1e-11 of the value (n ulps of log's rounding at n = 1e4) and the rounding of
            // g = sLsV cos 2t - ab carried through: where the lobe's peak g0 = sLsV - ab is a hair
            // above zero, g cancels to a few ulps of sLsV and one ulp of a sine moves S by
            // percents, in the scalar nodes as much as in the lanes (cond = sLsV / g0 counts it).
            const double sLsV = std::hypot(d.lb, d.ln) * std::hypot(d.vb, d.vn);
            const double cond = sLsV / std::max(1e-300, std::abs(sLsV - d.a * d.b));
            auto off = [&](double x, double y, double scale) {
              return std::abs(x - y) /
                     ((1e-11 + 1e-15 * n * cond) * std::abs(scale) + 1e-15 * (rel ? cond : 1.0));
            };
            ASSERT_EQ(D[0], D[1]);
            worst = std::max(worst, off(S[0], S[1], S[1]));
            double jscale = std::abs(Sj[1].a);
            for (int j = 0; j < 3; ++j) jscale = std::max(jscale, std::abs(Sj[1].v[j]));
            worst_jet = std::max(worst_jet, off(Sj[0].a, Sj[1].a, jscale));
            for (int j = 0; j < 3; ++j)
              worst_jet = std::max(worst_jet, off(Sj[0].v[j], Sj[1].v[j], jscale));
            ASSERT_LT(worst_jet, 1) << "n " << n << " order " << order << " s " << s << " value "
                                    << Sj[1].a << " lanes " << Sj[0].a;
          }
  std::printf(
      "lanes vs scalar nodes, %zu lit cases: worst difference of S %.2f, of the Jet's value "
      "and derivatives %.2f, of the tolerance\n",
      lit, worst, worst_jet);
  EXPECT_GT(lit, 10000u * widths.size());
  EXPECT_LT(worst, 1);
}

TEST(FiberModel, VisibleWidthIsTheProjectedPeriod) {  // identity 1
  std::mt19937_64 rng(1);
  for (int i = 0; i < 300; ++i) {
    const Dirs d = random_dirs(rng);
    for (double s : {0.0, 0.3, 0.77, 1.0}) {
      double D, S, W;
      fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, 20.0, s, FiberAccuracy{}, &D, &S, &W);
      const double P = 4 * std::cos(M_PI / 3 * s);
      EXPECT_NEAR(W, P * d.vn / std::hypot(d.vb, d.vn), 1e-12);
      if (i % 30 == 0) {
        const auto r =
            reference::fiber_bruteforce(d.lb, d.ln, d.vb, d.vn, d.a, d.b, 20.0, s, 20000);
        EXPECT_NEAR(r.W, W, 2e-3 * W) << "s=" << s;
      }
    }
  }
}

TEST(FiberModel, TopologyOneLooksLikeTopologyZero) {  // identity 2
  std::mt19937_64 rng(2);
  for (int i = 0; i < 2000; ++i) {
    const Dirs d = random_dirs(rng);
    double D0, S0, D1, S1;
    fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, 30.0, 0.0, FiberAccuracy{}, &D0, &S0);
    fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, 30.0, 1.0, FiberAccuracy{}, &D1, &S1);
    EXPECT_NEAR(D0, D1, 1e-9);
    EXPECT_NEAR(S0, S1, 1e-6 * std::max(1.0, S0));
  }
}

TEST(FiberModel, DiffuseNeverExceedsTheLineModel) {  // identity 3
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 20000; ++i) {
    const Dirs d = random_dirs(rng);
    double D, S;
    fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, 10.0, u(rng), FiberAccuracy{}, &D, &S);
    EXPECT_GE(D, 0.0);
    EXPECT_LE(D, std::sqrt(1 - d.a * d.a) + 1e-12);
  }
}

TEST(FiberModel, FlatPlaneLimitGivesLambert) {  // identity 4, on the reference
  std::mt19937_64 rng(4);
  for (int i = 0; i < 100; ++i) {
    const Dirs d = random_dirs(rng);
    const auto r =
        reference::fiber_bruteforce(d.lb, d.ln, d.vb, d.vn, d.a, d.b, 10.0, 0.0, 10, true);
    EXPECT_NEAR(r.D, d.ln, 1e-12);  // <N,L>
  }
}

TEST(FiberModel, FiberSignAndSwapSymmetry) {  // identity 5
  std::mt19937_64 rng(5);
  for (int i = 0; i < 2000; ++i) {
    const Dirs d = random_dirs(rng);
    double D, S, Df, Sf;
    fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, 25.0, 0.4, FiberAccuracy{}, &D, &S);
    // T -> -T: B = N x T flips too, so every component along T and B changes sign.
    fiber_DS(-d.lb, d.ln, -d.vb, d.vn, -d.a, -d.b, 25.0, 0.4, FiberAccuracy{}, &Df, &Sf);
    EXPECT_NEAR(D, Df, 1e-12);
    EXPECT_NEAR(S, Sf, 1e-9 * std::max(1.0, S));
    // Swapping L and V: the lit-and-visible set and <R,V> are symmetric, so S W_V / (s_V <.,v>)
    // weighting aside, the line-model peak s_L s_V - ab is unchanged.
    const double sL = std::hypot(d.lb, d.ln), sV = std::hypot(d.vb, d.vn);
    EXPECT_NEAR(sL * sV - d.a * d.b, sV * sL - d.b * d.a, 1e-15);
  }
}

double rel_err(double x, double ref, double scale) {
  return std::abs(x - ref) / std::max(std::abs(ref), scale);
}

TEST(FiberModel, MatchesBruteForceOverRandomAndAdversarialDirections) {
  std::mt19937_64 rng(6);
  std::vector<Dirs> cases = adversarial();
  for (int i = 0; i < 60; ++i) cases.push_back(random_dirs(rng));
  double worst_d = 0, worst_s = 0;
  for (const Dirs& d : cases)
    for (double s : {0.0, 0.5, 1.0})
      for (double n : {1.0, 40.0, 2000.0}) {
        double D, S;
        fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, n, s, FiberAccuracy{}, &D, &S);
        // The reference needs many samples to resolve a sharp lobe clipped by hiding.
        const int samples = 24000;
        const auto r = reference::fiber_bruteforce(d.lb, d.ln, d.vb, d.vn, d.a, d.b, n, s, samples);
        // Tolerance: the reference's midpoint rule errs by about one sample (pi/2000) at each
        // interval end; measured worst cases are printed.
        const double ed = std::abs(D - r.D), es = rel_err(S, r.S, 1e-3);
        worst_d = std::max(worst_d, ed);
        worst_s = std::max(worst_s, es);
        EXPECT_LT(ed, 5e-3) << "s=" << s << " n=" << n << " L=(" << d.a << "," << d.lb << ","
                            << d.ln << ") V=(" << d.b << "," << d.vb << "," << d.vn << ")";
        EXPECT_LT(es, 1e-2) << "S=" << S << " ref=" << r.S << " n=" << n << " s=" << s;
      }
  std::printf(
      "fast vs brute force (24000 samples/fiber) over %zu direction pairs x 9: max |dD| = %.2e, "
      "max rel dS = %.2e\n",
      cases.size(), worst_d, worst_s);
}

TEST(FiberModel, QuadratureConvergesForSharpLobes) {
  std::mt19937_64 rng(7);
  double worst = 0;
  for (int i = 0; i < 2000; ++i) {
    const Dirs d = random_dirs(rng);
    for (double n : {1.0, 100.0, 1e4}) {
      double D, S8, S32;
      fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, n, 0.5, FiberAccuracy{8}, &D, &S8);
      fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, n, 0.5, FiberAccuracy{32}, &D, &S32);
      worst = std::max(worst, rel_err(S8, S32, 1e-6));
    }
  }
  std::printf("order 8 vs order 32: worst relative difference of S %.2e\n", worst);
  EXPECT_LT(worst, 1e-4);
}

TEST(FiberModel, FiniteEverywhere) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(0, 1);
  size_t bad = 0;
  for (int i = 0; i < 200000; ++i) {
    Dirs d = random_dirs(rng);
    if (i % 7 == 0) d.vn = 1e-12;  // grazing view
    if (i % 11 == 0) {             // T parallel to L
      d.a = 1;
      d.lb = 0;
      d.ln = 0;
    }
    const double n = i % 3 == 0 ? 1.0 : (i % 3 == 1 ? 1e4 : 50.0);
    const double s = i % 5 == 0 ? 0.0 : (i % 5 == 1 ? 1.0 : u(rng));
    double D, S;
    fiber_DS(d.lb, d.ln, d.vb, d.vn, d.a, d.b, n, s, FiberAccuracy{}, &D, &S);
    bad += !std::isfinite(D) || !std::isfinite(S) || D < 0 || S < 0;
  }
  EXPECT_EQ(bad, 0u);
}

// Derivatives through moving interval end points: Jets against central differences in psi, s, n.
TEST(FiberModel, JetDerivativesMatchNumericIncludingMovingLimits) {
  using J = ceres::Jet<double, 3>;
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g;
  int checked = 0;
  for (int i = 0; i < 200; ++i) {
    auto unit = [&]() {
      double x = g(rng), y = g(rng), z = std::abs(g(rng)) + 0.05;
      const double l = std::sqrt(x * x + y * y + z * z);
      return LocalDir{x / l, y / l, z / l};
    };
    const LocalDir L = unit(), V = unit();
    const double x0[3] = {0.4, 0.35, std::log(30.0)};  // psi, s, log n
    auto f = [&](double psi, double s, double logn) {
      LineParamsT<double> p;
      for (int k = 0; k < 3; ++k) {
        p.kd[k] = 0.2;
        p.ks[k] = 0.5;
      }
      p.n = std::exp(logn);
      p.psi = psi;
      double out[3];
      fiber_reflectance(p, s, L, V, FiberAccuracy{16}, out);
      return out[0];
    };
    LineParamsT<J> p;
    for (int k = 0; k < 3; ++k) {
      p.kd[k] = J(0.2);
      p.ks[k] = J(0.5);
    }
    p.psi = J(x0[0], 0);
    const J s(x0[1], 1);
    p.n = exp(J(x0[2], 2));
    J out[3];
    fiber_reflectance(p, s, L, V, FiberAccuracy{16}, out);
    for (int k = 0; k < 3; ++k) {
      double xp[3] = {x0[0], x0[1], x0[2]}, xm[3] = {x0[0], x0[1], x0[2]};
      const double h = 1e-6;
      xp[k] += h;
      xm[k] -= h;
      const double num = (f(xp[0], xp[1], xp[2]) - f(xm[0], xm[1], xm[2])) / (2 * h);
      ASSERT_TRUE(std::isfinite(out[0].v[k]));
      EXPECT_NEAR(out[0].v[k], num, 2e-4 * std::max(1.0, std::abs(num)))
          << "param " << k << " case " << i;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 600);
}

TEST(FiberModel, TorusMathematicalTopology) {
  // Outside (v = 0): c = 1, flat. Where the circumference halves, c = 2 -> c' = 1 again (flat).
  EXPECT_NEAR(torus_mathematical_s(1.0, 0.5, 0.0), 0.0, 1e-12);
  const double R = 1.0, r = 0.6;
  const double v_half = std::acos(((R + r) / 2 - R) / r);             // R + r cos v = (R + r)/2
  EXPECT_NEAR(torus_mathematical_s(R, r, v_half + 1e-9), 0.0, 1e-3);  // acos(1/(1+e)) ~ sqrt(2e)
  EXPECT_GT(torus_mathematical_s(R, r, v_half - 0.05), 0.9);          // just before: close packed
  EXPECT_NEAR(topology_with_map(0.0, 0.25, 0.0), 0.0, 1e-12);
  EXPECT_NEAR(topology_with_map(1.0, 0.25, 1.0), 1.0, 1e-12);  // clamped at sqrt 3
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// Found by fuzz/fuzz_model.cpp (tests/fuzz_regressions/model_grazing_view_negative_D.bin): a view
// 7e-14 above the surface made W ~ 1e-13 and rounding pushed D below zero.
TEST(FiberModel, ExtremelyGrazingViewStaysWithinBounds) {
  const double psi = -72 * M_PI / 180, c = std::cos(psi), sn = std::sin(psi);
  const LocalDir L{1.3e-82, 0.99999999999272404, 3.8146972655972444e-06},
      V{1, 2.8e-221, 7.1054227188982636e-14};
  const double a = c * L.u + sn * L.w, b = c * V.u + sn * V.w;
  const double lb = c * L.w - sn * L.u, vb = c * V.w - sn * V.u;
  double D, S;
  fiber_DS(lb, L.n, vb, V.n, a, b, 1.5, 0.5, FiberAccuracy{}, &D, &S);
  EXPECT_GE(D, 0.0);
  EXPECT_LE(D, std::sqrt(1 - a * a));
  EXPECT_GE(S, 0.0);
  EXPECT_TRUE(std::isfinite(D) && std::isfinite(S));
}

}  // namespace
}  // namespace aniso

#include "capture_sim/sim.h"
#include "datasets_synth/presets.h"
#include "fit/fit.h"
#include "io/formats/capture.h"
#include "test_util.h"

namespace aniso {
namespace {

// The fiber model's fused solve (fit/solvers/fiber_solve.h: Jets of size 3 through the quadrature)
// against Ceres (the fitter of record, Jets of size 9), at the same quadrature order, on a flat
// sample (the topology s) and a torus with a topology map (its amplitude A): the same minimum
// within a tenth of sigma, the same sigmas within 5 %. Then the order chosen from the noise against
// order 16: the fit moves by at most 0.05 sigma.
TEST(FitFiber, FusedSolverAndCeresReachTheSameMinimum) {
  for (const std::string preset : {"fiber-flat", "silk-torus"}) {
    PresetOptions p;
    p.views = 6;  // small: the sanitizer run takes each Ceres pass through the quadrature
    p.width = p.height = 48;
    p.noise = 0.01;
    p.topology_s = 0.3;
    p.topology_amplitude = 0.3;
    p.progress = nullptr;
    const std::string dir = test::tmp_dir("fiber_paths_" + preset);
    simulate_capture(make_preset(preset, p), dir);
    const CaptureSet set = read_capture(dir);
    FitOptions fused;
    fused.progress = nullptr;
    fused.model = FitModel::kFiber;
    fused.fiber_order = 8;
    FitOptions ceres = fused, automatic = fused, reference = fused;
    ceres.ceres_solver = true;
    automatic.fiber_order = 0;
    reference.fiber_order = 16;
    const FitResult ra = fit_capture(set, fused), rb = fit_capture(set, ceres);
    EXPECT_EQ(ra.report.solver, "fused LM");
    EXPECT_EQ(rb.report.solver, "ceres");
    const std::string topo = preset == "fiber-flat" ? "topology.s" : "topology.amplitude";
    auto topology = [&](const FitResult& r) {
      if (const auto* u = r.material.topology_as<UniformS>()) return u->s;
      return r.material.topology_as<TopologyMapRef>()->amplitude;
    };
    // Every fitted number of a against b, in b's sigma; the sigmas against each other.
    auto worst = [&](const FitResult& a, const FitResult& b, bool sigmas) {
      double w = 0;
      auto near = [&](double x, double y, double sx, double sy) {
        w = std::max(w, std::abs(x - y) / sy);
        if (sigmas) {
          EXPECT_NEAR(sx, sy, 0.05 * sy) << preset;
        }
      };
      for (int k = 0; k < 3; ++k) {
        near(a.material.kd[k], b.material.kd[k], a.sigma.at("kd")[k], b.sigma.at("kd")[k]);
        near(a.material.ks[k], b.material.ks[k], a.sigma.at("ks")[k], b.sigma.at("ks")[k]);
      }
      near(a.material.n, b.material.n, a.sigma.at("n")[0], b.sigma.at("n")[0]);
      near(a.material.fiber_angle_deg, b.material.fiber_angle_deg, a.sigma.at("fiber_angle_deg")[0],
           b.sigma.at("fiber_angle_deg")[0]);
      near(topology(a), topology(b), a.sigma.at(topo)[0], b.sigma.at(topo)[0]);
      return w;
    };
    const double fused_vs_ceres = worst(ra, rb, true);
    const FitResult rc = fit_capture(set, automatic), rd = fit_capture(set, reference);
    const double order_shift = worst(rc, rd, false);
    std::printf(
        "%s: fused LM vs Ceres (order 8) worst %.4f sigma, solve %.3f s vs %.3f s; chosen order "
        "vs order 16 worst %.4f sigma (%s)\n",
        preset.c_str(), fused_vs_ceres, ra.report.seconds_solve, rb.report.seconds_solve,
        order_shift, rc.report.start.substr(rc.report.start.find("quadrature")).c_str());
    EXPECT_LT(fused_vs_ceres, 0.1) << preset;
    EXPECT_LT(order_shift, 0.05) << preset;
    EXPECT_NE(rc.report.start.find("quadrature order"), std::string::npos);
  }
}

}  // namespace
}  // namespace aniso
