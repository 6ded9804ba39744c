// fit/ internal: a capture's fit with a photo shoot's steps around it (fit/fit_steps.cpp): the
// lamps placed by the sample's highlight where the capture states their sigma or
// --lamps-from-highlight asks, the lamps a --global material was made under, and the fiber
// direction from the highlight's symmetry where the line model misses the data.
#pragma once
#include "fit/types/fit_types.h"

namespace aniso {

// The fit of `set` as asked, without those steps (fit/fit.cpp).
FitResult fit_capture_here(const CaptureSet& set, const FitOptions& opt);
// With them: what fit_capture runs on its threads.
FitResult fit_capture_steps(const CaptureSet& set, const FitOptions& opt);

}  // namespace aniso
