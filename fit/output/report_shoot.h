// fit/ internal: the report's blocks of what a fit of a photo shoot's capture did beyond the fit
// itself: the lamps placed by the highlight, the fiber direction from the highlight's symmetry
// (docs/formats.md, the material's report).
#pragma once
#include "fit/types/fit_types.h"
#include "io/files/json_util.h"

namespace aniso {

jsonu::json lamps_from_highlight_json(const FitReport::LampsFromHighlight& h);
jsonu::json psi_from_symmetry_json(const FitReport::PsiFromSymmetry& p);
// The lamps a fit was made under where the highlight placed them (report.lamps_from_highlight
// used; none otherwise): view, light, found_m and found_sigma_m of each. A malformed block is an
// error naming `file`.
std::vector<LampPlaced> lamps_placed_read_back(const jsonu::json& report, const std::string& file);

}  // namespace aniso
