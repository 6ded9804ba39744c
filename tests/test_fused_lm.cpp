// The fused Levenberg-Marquardt loop's stopping and bound rules (fit/solvers/fused_lm.h), on
// problems whose answer is known in closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "fit/global/isotropic_alternative.h"
#include "fit/global/view_sandwich.h"
#include "fit/records/observations.h"
#include "fit/solvers/fused_lm.h"
#include "io/formats/capture.h"
#include "io/formats/rgl_bsdf.h"
#include "io/formats/table.h"
#include "test_util.h"

namespace aniso::fitting {
namespace {

using V8 = VecP<8>;
using M8 = MatP<8>;

// A coupled positive definite matrix: every coordinate correlated with its neighbours.
M8 coupled_matrix() {
  M8 H = M8::Zero();
  for (int k = 0; k < 8; ++k) {
    H(k, k) = 4.0 + k;
    if (k + 1 < 8) H(k, k + 1) = H(k + 1, k) = 1.5;
  }
  return H;
}

// The sums of cost(x) = (x - a)^T H (x - a) + floor, as a pass over `values` values gives them
// (cost and rss alike: no robust loss; g = J^T r = H (x - a)).
FusedSums<8> quadratic_sums(const M8& H, const V8& a, double floor, const V8& x) {
  FusedSums<8> s;
  const V8 d = x - a;
  s.H = H;
  s.g = H * d;
  s.cost = s.rss = d.dot(H * d) + floor;
  return s;
}

TEST(FitSolvers, AFitAtABoundConverges) {
  // The unconstrained minimum has k_d,r (coordinate 0) at -0.5, outside its bound 0: the answer
  // is the minimum with k_d,r held at 0, the others moved by the coupling (-H_ff^-1 H_f0 (0 - a0)).
  const M8 H = coupled_matrix();
  V8 a;
  a << -0.5, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.2;
  V8 lo = V8::Constant(-10), hi = V8::Constant(10);
  lo(0) = 0;
  const double values = 1000, floor = 990;  // residual variance 1
  V8 expect = a;
  expect(0) = 0;
  const Eigen::Matrix<double, 7, 7> Hff = H.bottomRightCorner<7, 7>();
  expect.tail<7>() = a.tail<7>() - Hff.ldlt().solve(H.block<7, 1>(1, 0) * (0 - a(0)));
  V8 x = V8::Constant(0.1);
  FusedSums<8> cur;
  FusedSolve out;
  fused_lm<8>([&](const V8& at, bool) { return quadratic_sums(H, a, floor, at); }, lo, hi, values,
              200, &x, &cur, &out);
  std::printf("at a bound: %d iterations, %d passes, converged %d, largest error %.2g\n",
              out.iterations, out.passes, out.converged, (x - expect).cwiseAbs().maxCoeff());
  EXPECT_TRUE(out.converged);
  EXPECT_LE(out.iterations, 10);
  EXPECT_EQ(x(0), 0.0);
  EXPECT_LT((x - expect).cwiseAbs().maxCoeff(), 1e-4);  // sigma ~0.5: the loop stops under 1e-3
}

TEST(FitSolvers, AFusedCrawlStopsWithinATenthSigma) {
  // The rest of a geometric series: falls 3.0 then 2.2 (ratio 0.733) leave 2.2 * 0.733 / 0.267 =
  // 6.05 of the sum of squares, 6.05 / 3.3 = 1.83 in chi^2 at a residual variance 3.3.
  EXPECT_NEAR(crawl_left_chi2(3.0, 2.2, 3.3), 2.2 * (2.2 / 3.0) / (1 - 2.2 / 3.0) / 3.3, 1e-12);
  EXPECT_EQ(crawl_left_chi2(2.0, 2.5, 1.0), HUGE_VAL);  // not shrinking: nothing to estimate
  EXPECT_EQ(crawl_left_chi2(0.0, 0.0, 1.0), HUGE_VAL);

  // A crawl: every step accepted, its size many sigma (the steps' own rule never stops it), the
  // cost falling toward `floor` by 0.8 a step. After 30 steps what is left is 0.8^30 of the first
  // fall, 1.2e-3 in chi^2: under the rule's 0.01, where after 20 it was 0.012 (the windows' own
  // estimates alike).
  const double values = 1e6, floor = 1e6 - 8;  // residual variance 1
  int calls = 0;
  auto pass = [&](const V8&, bool) {
    FusedSums<8> s;
    s.H = M8::Identity();
    s.g = V8::Constant(-1e6);  // steps of many sigma however damped
    s.cost = s.rss = floor + std::pow(0.8, calls++);
    return s;
  };
  V8 x = V8::Zero(), lo = V8::Constant(-1e9), hi = V8::Constant(1e9);
  FusedSums<8> cur;
  FusedSolve out;
  fused_lm<8>(pass, lo, hi, values, 200, &x, &cur, &out);
  const double left = cur.cost - floor;
  std::printf("crawl: %d steps, crawled %d, chi^2 left %.2g\n", out.iterations, out.crawled, left);
  EXPECT_TRUE(out.crawled);
  EXPECT_EQ(out.iterations, 30);
  EXPECT_LT(left, kCrawlLeftChi2);
}

TEST(FitSolvers, TheIsotropicPartFusedAsCeres) {
  // The isotropic part alone (the anisotropy test's) by the fused solver and by Ceres from the
  // same grid start, on both measured files of tests/data/rgl under Huber at a scale of a
  // tenth of the readings' mean: the same minimum (the fused one no higher by more than 1e-6 of
  // the cost, the numbers within 1e-3 relative).
  for (const char* name : {"paper_white_rgb.bsdf", "satin_rosaline_rgb.bsdf"}) {
    const SampleTable table =
        measured_table(RglBsdf::read(std::string(ANISO_SOURCE_DIR) + "/tests/data/rgl/" + name));
    FitOptions opt;
    opt.progress = nullptr;
    FitReport rep;
    const ObsSet os = table_observations(table, opt, &rep);
    double mean = 0;
    for (const auto& o : os.obs) mean += (o.y[0] + o.y[1] + o.y[2]) / 3.0;
    mean /= double(os.obs.size());
    const size_t stride = 2;
    const IsotropicFit fused = fit_isotropic_part(os, stride, opt, 0.1 * mean);
    FitOptions ceres = opt;
    ceres.ceres_solver = true;
    const IsotropicFit ref = fit_isotropic_part(os, stride, ceres, 0.1 * mean);
    std::printf(
        "%s: fused cost %.9g (n_iso %.4f, k_s,iso %.5f), Ceres %.9g (n_iso %.4f, k_s,iso %.5f)\n",
        name, fused.cost, fused.n, fused.ks[1], ref.cost, ref.n, ref.ks[1]);
    EXPECT_TRUE(fused.converged);
    EXPECT_LE(fused.cost, ref.cost * (1 + 1e-6));
    EXPECT_NEAR(fused.n, ref.n, 1e-3 * ref.n);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(fused.kd[c], ref.kd[c], 1e-3 * std::max(ref.kd[c], 1e-2));
      EXPECT_NEAR(fused.ks[c], ref.ks[c], 1e-3 * std::max(ref.ks[c], 1e-2));
    }
  }
}

TEST(FitSolvers, TheViewsSpreadFromRowsAsFromDifferences) {
  // The views' sandwich (fit/global/view_sandwich.h) of the fiber model, its per-view gradients
  // from the fused solver's rows in one pass and by central differences of the residual, at a
  // point off the minimum (the residuals large, so both sums are far from rounding): the same
  // covariance to the differences' precision.
  const std::string dir = test::tmp_dir("view_rows");
  auto r =
      test::run_cli("synth brushed-metal " + dir + "/set --noise 0.01 --size 48x48 --views 12");
  ASSERT_EQ(r.status, 0) << r.output;
  FitOptions opt;
  opt.progress = nullptr;
  opt.model = FitModel::kFiber;
  FitReport rep;
  const ObsSet os = capture_observations(read_capture(dir + "/set"), opt, &rep);
  std::unique_ptr<ModelFit> m = make_fiber_fit(opt, os);
  m->start(os, nullptr);
  m->core.psi += 0.05;
  std::vector<std::pair<double*, int>> blocks = {
      {m->core.kd, 3}, {m->core.ks, 3}, {&m->core.logn, 1}, {&m->core.psi, 1}};
  std::vector<double> ainv(64, 0.0);
  for (int k = 0; k < 8; ++k) ainv[9 * k] = 1.0;
  size_t views_rows = 0, views_diff = 0;
  const std::vector<double> rows = per_view_covariance(m.get(), os, blocks, ainv, 2, &views_rows);
  const std::vector<double> diff =
      per_view_covariance(m.get(), os, blocks, ainv, 2, &views_diff, true);
  ASSERT_EQ(rows.size(), 64u);
  ASSERT_EQ(diff.size(), 64u);
  EXPECT_EQ(views_rows, views_diff);
  double worst = 0;
  for (int k = 0; k < 8; ++k) {
    const double a = std::sqrt(rows[9 * k]), b = std::sqrt(diff[9 * k]);
    worst = std::max(worst, std::abs(a - b) / b);
  }
  std::printf("views' sigma from rows and from differences: largest relative difference %.2g\n",
              worst);
  EXPECT_LT(worst, 1e-5);
  // The same bits on one thread as on two, both ways (sums over fixed chunks, added in order).
  size_t views_one = 0;
  EXPECT_TRUE(per_view_covariance(m.get(), os, blocks, ainv, 1, &views_one) == rows);
  EXPECT_TRUE(per_view_covariance(m.get(), os, blocks, ainv, 1, &views_one, true) == diff);
}

}  // namespace
}  // namespace aniso::fitting
