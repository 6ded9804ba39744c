// fit/ internal: the uncertainty that errors shared by a view's pixels add. A photo shoot's pose,
// lamp and calibration errors, and a model that misses the material, do not scatter independently
// pixel by pixel as the images' noise does: each moves a whole view's pixels together, and the
// covariance from the residuals' pixel-by-pixel spread (J^T J)^-1 s^2 is then 30-90 times too
// small. The cluster-robust ("sandwich") covariance over views,
//   C = G / (G - P) (J^T J)^-1 [sum over views v of g_v g_v^T] (J^T J)^-1,  g_v = J_v^T r_v,
// measures the spread the views' own residuals show, whatever shared error caused it; with exact
// geometry and a model that fits, it is the noise's covariance again (on average).
#pragma once
#include <utility>
#include <vector>

#include "fit/records/observations.h"

namespace aniso::fitting {

class ModelFit;

// The covariance C above over the free parameter blocks `blocks` (pointer into m's state, size),
// P coordinates in all, given (J^T J)^-1 over the same coordinates (`ainv`, P x P row-major).
// J_v from the model's rows in one pass where it gives them (ModelFit::residual_row) unless
// `differences`, else by central differences of m.residual (each coordinate moved and restored
// in place). Empty
// where the set has no views (a table), fewer than P + 2 views with observations, or more than
// kMaxObservations (it holds 12 bytes an observation: the residuals at the solution).
inline constexpr size_t kMaxObservations = size_t{1} << 25;
std::vector<double> per_view_covariance(ModelFit* m, const ObsSet& os,
                                        const std::vector<std::pair<double*, int>>& blocks,
                                        const std::vector<double>& ainv, int threads,
                                        size_t* views_used, bool differences = false);

}  // namespace aniso::fitting
