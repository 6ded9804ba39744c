// `aniso report`: a fit a person can look at. From a material file that `fit` wrote (and,
// optionally, the capture it was fitted to), a folder with index.html that works offline: the
// parameters with their whole and noise-only sigma, the warnings apart from the notes, the maps'
// previews with the fiber direction as a field and sigma and coverage per texel, the correlation
// matrix, the solver's convergence, the phases' times; with the capture, each view's residual
// picture beside its RMS against the images' noise (render/preview/verify.h), the residuals
// against the unit Gaussian and the lobe against the data (render/report/report_figures.h).
#pragma once
#include <string>

namespace aniso {

struct ReportOptions {
  std::string material;  // FIT.json, as fit writes it
  std::string capture;   // "" or the capture set it was fitted to
  std::string out;       // the folder to write (atomically)
};

struct ReportSummary {
  size_t parameters = 0, warnings = 0, notes = 0, views = 0, maps = 0;
  size_t lobe_points = 0;
  bool correlation = false, convergence = false, direction_field = false;
};

ReportSummary write_report(const ReportOptions& o);

}  // namespace aniso
