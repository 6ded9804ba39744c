// fit/ internal: the fiber direction from the highlight's symmetry alone (docs/models.md "The fiber
// direction whatever the lobe"). Any lobe the line model stands for, and the microfacet lobes other
// renderers and real brushed metals have, is a mirror image of itself across the fiber and across
// its normal: f(L, V) = f(M L, M V) for M either mirror. The line model's own psi is the one its
// lobe's shape fits best; where that shape is not the data's, the views' disagreement makes psi
// uncertain by degrees. Here the lobe is any smooth function of the half vector's slopes across
// and along the fiber, |h_t| / h_n and |h_b| / h_n (a table, bilinear, with a smoothness prior),
// so only the symmetry places psi.
#pragma once
#include <string>
#include <vector>

#include "io/formats/capture.h"

namespace aniso::fitting {

struct PsiFromSymmetry {
  std::string skipped;       // why there is no estimate ("" where there is)
  double psi_deg = 0;        // the fiber angle in [0, 180)
  double sigma_deg = 0;      // a jackknife over views of psi_deg
  double start_psi_deg = 0;  // the fit's psi the search was centred on
  size_t pixels = 0, views = 0;
  // The weighted residual RMS of the free lobe's fit over that of the same pixels' mean: how much
  // of the signal the symmetric lobe draws (0 all of it).
  double relative_rms = 0;
  bool replicate_at_edge = false;  // a jackknife replicate's psi left the searched interval
  std::vector<double> jackknife_psi_deg;
  double seconds = 0;
};

// Views lit by one light (others are left out); pixels spread over each view's usable ones. The
// search covers start_psi_deg +- 45 degrees (the free lobe cannot tell a fiber from its normal).
PsiFromSymmetry psi_from_symmetry(const CaptureSet& set, double start_psi_deg, int threads);

}  // namespace aniso::fitting
