// fit/ internal: the fiber model's quadrature order chosen from the data. The
// specular integral is Gauss-Legendre on panels around the lobe's peak (models/fiber_model.h);
// its error is systematic, so over N values it can shift a fitted number by up to about
// error x sqrt(N) / noise of that number's sigma. The order kept is the smallest whose RMS error
// per value, against order 16 at the start point on a sample of pixels, stays under 1 % of
// noise / sqrt(N): a shift of at most ~0.01 sigma. Without a noise estimate (tables, noise-free
// renders) the default order 8.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "fit/solvers/model_fit.h"

namespace aniso::fitting {

struct FiberOrderChoice {
  int order = 8;
  double rms_error = 0;  // per value, of the order kept
  std::string note;      // for the report's start line
  FiberOrderErrors
      errors;  // each order's tried, up to the one kept (--maps' texels choose from them)
};

FiberOrderChoice choose_fiber_order(const ObsSet& os, const std::vector<size_t>& subset,
                                    const Core& c, const std::function<double(size_t)>& s_of);

}  // namespace aniso::fitting
