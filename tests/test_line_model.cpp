// Properties of the line-lighting model (docs/models.md §3, §6).
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "io/formats/table.h"
#include "models/evaluate.h"
#include "models/line_model.h"

namespace aniso {
namespace {

LocalDir random_dir(std::mt19937_64& rng, bool upper = true) {
  std::normal_distribution<double> g;
  double x = g(rng), y = g(rng), z = g(rng);
  const double l = std::sqrt(x * x + y * y + z * z);
  if (upper) z = std::abs(z);
  return {x / l, y / l, z / l};
}

Material test_material() {
  Material m;
  m.kd = {0.2, 0.3, 0.4};
  m.ks = {0.5, 0.6, 0.7};
  m.n = 35;
  m.fiber_angle_deg = 25;
  return m;
}

TEST(LineModel, FiberDirectionSignDoesNotMatter) {  // T -> -T (docs/models.md §1)
  std::mt19937_64 rng(1);
  Material a = test_material(), b = a;
  b.fiber_angle_deg = a.fiber_angle_deg + 180;
  const Evaluator ea(a), eb(b);
  for (int i = 0; i < 2000; ++i) {
    const LocalDir L = random_dir(rng), V = random_dir(rng);
    double fa[3], fb[3];
    ea(L, V, fa);
    eb(L, V, fb);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(fa[c], fb[c], 1e-12);
  }
}

TEST(LineModel, SpecularIsSymmetricInLAndV) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 2000; ++i) {
    const double a = u(rng), b = u(rng);
    double D1, S1, D2, S2;
    line_DS(a, b, 40.0, &D1, &S1);
    line_DS(b, a, 40.0, &D2, &S2);
    EXPECT_NEAR(S1, S2, 1e-14);
    EXPECT_NEAR(D1, std::sqrt(1 - a * a), 1e-12);
  }
}

TEST(LineModel, PeakOnTheReflectionCone) {
  // V on the cone of mirror directions (b = -a) gives <V,R> = 1, the lobe's maximum.
  for (double a : {-0.9, -0.3, 0.0, 0.4, 0.99}) {
    double D, S;
    line_DS(a, -a, 1000.0, &D, &S);
    EXPECT_NEAR(S, 1.0, 1e-9);
  }
}

TEST(LineModel, LightBelowHorizonGivesZero) {  // Banks' self-shadowing
  Material m = test_material();
  m.has_isotropic = true;
  m.iso_kd = {0.1, 0.1, 0.1};
  m.iso_ks = {0.3, 0.3, 0.3};
  const Evaluator e(m);
  double f[3];
  e({0.5, 0.5, -0.7071}, {0, 0.6, 0.8}, f);
  for (double v : f) EXPECT_EQ(v, 0.0);
}

TEST(LineModel, ZeroWeightTermsChangeNothing) {
  std::mt19937_64 rng(3);
  Material a = test_material(), b = a;
  b.has_isotropic = true;  // all-zero isotropic weights
  b.has_second_fiber = true;
  b.second_weight = 1.0;  // the second lobe gets weight 0
  EXPECT_FALSE(b.isotropic_active());
  EXPECT_FALSE(b.second_active());
  const Evaluator ea(a), eb(b);
  for (int i = 0; i < 500; ++i) {
    const LocalDir L = random_dir(rng), V = random_dir(rng);
    double fa[3], fb[3];
    ea(L, V, fa);
    eb(L, V, fb);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(fa[c], fb[c]);
  }
}

TEST(LineModel, SecondFiberMixesTwoLobes) {
  Material m = test_material();
  m.has_second_fiber = true;
  m.second_angle_deg = m.fiber_angle_deg + 90;
  m.second_weight = 0.3;
  Material m1 = test_material(), m2 = test_material();
  m2.fiber_angle_deg = m.second_angle_deg;
  const LocalDir L{0.3, 0.2, 0.9327}, V{-0.4, 0.1, 0.9110};
  double f[3], f1[3], f2[3];
  Evaluator{m}(L, V, f);
  Evaluator{m1}(L, V, f1);
  Evaluator{m2}(L, V, f2);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(f[c], 0.3 * f1[c] + 0.7 * f2[c], 1e-12);
}

TEST(LineModel, FiniteAtGrazingAndDegenerateDirections) {
  Material m = test_material();
  const Evaluator e(m);
  const LocalDir cases[] = {
      {1, 0, 0}, {-1, 0, 0}, {0, 0, 1}, {0.9063, 0.4226, 0}, {1, 1e-17, 1e-17}};
  for (double n : {1.0, 10.0, 1e4}) {
    m.n = n;
    const Evaluator en(m);
    for (const auto& L : cases)
      for (const auto& V : cases) {
        double f[3];
        en(L, V, f);
        for (double v : f) EXPECT_TRUE(std::isfinite(v));
      }
  }
  // L = V, T parallel to L (a = ±1), and 10^6 random directions incl. those below the horizon.
  std::mt19937_64 rng(4);
  size_t bad = 0;
  for (int i = 0; i < 1000000; ++i) {
    const LocalDir L = random_dir(rng, false), V = random_dir(rng, false);
    double f[3];
    e(L, V, f);
    for (double v : f) bad += !std::isfinite(v) || v < 0;
  }
  EXPECT_EQ(bad, 0u);
}

// Jet derivatives equal central differences, including a = <L,T> within 1e-6 of ±1 where
// d sqrt(1 - a^2)/da is large (docs/models.md §6).
TEST(LineModel, JetDerivativesMatchNumeric) {
  using J = ceres::Jet<double, 4>;
  std::mt19937_64 rng(5);
  auto eval = [](const LocalDir& L, const LocalDir& V, auto kd, auto ks, auto logn, auto psi) {
    using T = decltype(kd);
    using std::exp;
    LineParamsT<T> p;
    for (int k = 0; k < 3; ++k) {
      p.kd[k] = kd;
      p.ks[k] = ks;
    }
    p.n = exp(logn);
    p.psi = psi;
    T f[3];
    line_reflectance(p, L, V, f);
    return f[0];
  };
  std::vector<std::pair<LocalDir, LocalDir>> cases;
  for (int i = 0; i < 200; ++i) cases.push_back({random_dir(rng), random_dir(rng)});
  // Near a = ±1: L almost along T (psi = 0.3 rad) but just above the surface.
  for (double eps : {1e-3, 1e-5}) {
    const double c = std::cos(0.3), s = std::sin(0.3);
    const double z = std::sqrt(1 - (1 - eps) * (1 - eps));
    cases.push_back({{c * (1 - eps), s * (1 - eps), z}, {0.1, -0.2, 0.9747}});
    cases.push_back({{-c * (1 - eps), -s * (1 - eps), z}, {-0.3, 0.2, 0.9327}});
  }
  const double x[4] = {0.3, 0.6, std::log(30.0), 0.3};
  for (const auto& [L, V] : cases) {
    const J r = eval(L, V, J(x[0], 0), J(x[1], 1), J(x[2], 2), J(x[3], 3));
    for (int k = 0; k < 4; ++k) {
      double xp[4], xm[4];
      std::copy(x, x + 4, xp);
      std::copy(x, x + 4, xm);
      const double h = 1e-7;
      xp[k] += h;
      xm[k] -= h;
      const double num =
          (eval(L, V, xp[0], xp[1], xp[2], xp[3]) - eval(L, V, xm[0], xm[1], xm[2], xm[3])) /
          (2 * h);
      EXPECT_TRUE(std::isfinite(r.v[k]));
      EXPECT_NEAR(r.v[k], num, 1e-5 * std::max(1.0, std::abs(num))) << "param " << k;
    }
  }
}

TEST(LineModel, SafeSqrtStaysFiniteAtExactlyOne) {
  using J = ceres::Jet<double, 1>;
  const J a(1.0, 0);
  const J s = sin_from_cos(a);
  EXPECT_EQ(s.a, 0.0);
  EXPECT_TRUE(std::isfinite(s.v[0]));
  const J b(1.0 - 1e-14, 0);  // inside the chord region: finite, bounded derivative
  const J t = sin_from_cos(b);
  EXPECT_TRUE(std::isfinite(t.v[0]));
  EXPECT_LE(std::abs(t.v[0]), 1e6 * 2.1);
}

TEST(LineModel, SampleTableAnglesMatchFrame) {
  const LocalDir d = dir_from_angles(90, 90);  // in the plane, toward N x U
  EXPECT_NEAR(d.u, 0, 1e-12);
  EXPECT_NEAR(d.w, 1, 1e-12);
  EXPECT_NEAR(d.n, 0, 1e-12);
}

}  // namespace
}  // namespace aniso
