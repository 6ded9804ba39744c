// The noise of an image from second differences of neighbouring pixels (x - 1, x, x + 1): robust
// (a median), and blind to smooth signal, so what a perfect model would leave as its residual.
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

namespace aniso {

// One channel's sigma from its second differences I(x-1) - 2 I(x) + I(x+1) (any sign; reordered
// in place): 1.4826 median |d| / sqrt(6). 0 where there are none.
inline double second_difference_noise(std::vector<float>* diffs) {
  if (diffs->empty()) return 0;
  for (float& v : *diffs) v = std::abs(v);
  const auto mid = diffs->begin() + diffs->size() / 2;
  std::nth_element(diffs->begin(), mid, diffs->end());
  return 1.4826 * *mid / std::sqrt(6.0);
}

}  // namespace aniso
