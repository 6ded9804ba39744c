// fit: recovers the line-lighting model's parameters from a capture set or a sample table with
// Ceres (docs/models.md §3, §6). Observations are (pixel, channel) values; k_d, k_s (RGB), log n
// and the fiber angle psi (on a periodic manifold, modulo 180 degrees) are fitted, plus the
// optional isotropic and second-fiber terms when asked. The start comes from a deterministic grid
// over (psi, n) with k_d, k_s solved in closed form at each node, so it does not depend on luck.
#pragma once
#include <string>
#include <vector>

#include "fit/output/report.h"
#include "fit/types/fit_types.h"

namespace aniso {

// The threads a fit may use here: the cores this process may run on (its CPU affinity and
// cgroup's quota, as TBB reads them): --threads' default.
int default_fit_threads();
FitResult fit_capture(const CaptureSet& set, const FitOptions& opt);
FitResult fit_table(const SampleTable& table, const FitOptions& opt);

// For benchmarks against other solvers: the observations of a capture as a flat little-endian
// float64 file, one row of 14 per pixel with one light
// (Vu Vw Vn  Lu Lw Ln  Er Eg Eb  yr yg yb  smath mapv), and the start point this fitter's grid
// chose for the line model (kd[3] ks[3] log n psi). Returns the number of rows.
size_t export_observations(const CaptureSet& set, const FitOptions& opt, const std::string& path,
                           std::vector<double>* start);

}  // namespace aniso
