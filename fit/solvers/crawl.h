// When a solve that only crawls is done: the rule fused_lm.h's loop and the global fit's Ceres
// solve (fit/global/solve.cpp) share.
#pragma once
#include <cmath>

namespace aniso::fitting {

// A crawl: where the steps stay damped in a curved valley (the fiber model's quadrature under a
// robust loss on an isotropic measured file: ~1e-2 sigma a step, the cost falling by a steady
// ratio a window), the fall of the sum of squares over each kCrawlWindow accepted steps is
// compared with the window's before. Falling by a steady ratio q < 1, what is left to gain is the
// rest of that geometric series, D q / (1 - q); the fit is done when that is under kCrawlLeftChi2
// in units of the residual variance (chi^2: 0.01 is a tenth of a sigma along the valley). A fit
// that converges quadratically stops on its step's size first. Test:
// FitSolvers.AFusedCrawlStopsWithinATenthSigma.
constexpr int kCrawlWindow = 10;
constexpr double kCrawlLeftChi2 = 0.01;

// The chi^2 a crawl has left to gain: the windows' falls `before` and `last` of the sum of
// squares, `s2` the residual variance. Infinite where the falls are not shrinking.
inline double crawl_left_chi2(double before, double last, double s2) {
  if (!(before > 0 && last >= 0 && last < before && s2 > 0)) return HUGE_VAL;
  const double q = last / before;
  return last * q / (1 - q) / s2;
}

// The rule over a solve: started at its first cost, told the sum of squares' cost after each
// accepted step with the residual variance there; true when the crawl is done.
class CrawlWatch {
 public:
  explicit CrawlWatch(double cost) : from_(cost) {}
  bool accepted(double cost, double s2) {
    if (++steps_ % kCrawlWindow) return false;
    const double fell = from_ - cost;
    const bool done = before_ > 0 && crawl_left_chi2(before_, fell, s2) < kCrawlLeftChi2;
    from_ = cost, before_ = fell;
    return done;
  }

 private:
  double from_, before_ = -1;
  int steps_ = 0;
};

}  // namespace aniso::fitting
