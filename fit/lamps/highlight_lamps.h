// fit/ internal: a photo shoot's lamps from the sample's own highlight (docs/photo-shoot.md
// "The lamps from the sample's highlight"). The board's paper places each lamp within its sigma;
// the sample's highlight places it again, but only together with the material: the material fitted
// under the paper's lamps has absorbed their errors, and a lamp solved afterwards from that
// material returns the paper's place. So each point lamp's position is a parameter of one problem
// with the line model's material (k_d, k_s, n, psi), the position stated in the capture
// (Light::position_sigma_m) its prior, and the images' pixels its data.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "core/vec.h"
#include "io/formats/capture.h"
#include "models/material.h"

namespace aniso::fitting {

// One lamp as the joint problem found it.
struct HighlightLamp {
  size_t view = 0, light = 0;
  Vec3 given;               // as the capture states it
  Vec3 prior_sigma_m;       // its sigma as stated (or the default where the capture states none)
  bool stated = false;      // the capture stated that sigma
  Vec3 found;               // where the joint problem puts it
  Vec3 sigma_m{0, 0, 0};    // of `found`, per world axis
  double moved_sigmas = 0;  // |found - given| in the prior's sigmas (Mahalanobis, per axis)
  // Moved more than kLampMovedSigmas by the first solve: its prior was then widened
  // kReleasedPriorScale times and the problem solved again (the position written is wrong).
  bool released = false;
  size_t pixels = 0;  // of this view in the problem
};

struct HighlightLamps {
  std::vector<HighlightLamp> lamps;  // one per point lamp placed (views with one point lamp)
  Material material;                 // the joint problem's material (the line model)
  size_t pixels = 0, views_left_out = 0;
  double pixel_sigma = 0;  // the residuals' sigma the data were weighted by
  double cost_before = 0, cost_after = 0;
  int iterations = 0;
  double seconds = 0;
  std::string skipped;  // why no lamp was placed ("" where they were)
  // The material's spread over the views: the joint problem solved again without each view in
  // turn (a jackknife over views, (V - 1) / V times the replicates' variance about their mean),
  // per number k_d (3), k_s (3), n, psi (degrees); empty with fewer than kMinJackknifeViews views.
  std::vector<double> jackknife_sigma;
  size_t jackknife_views = 0;
  // The lamps' sigma is what the problem says of them times this: the jackknife's spread of the
  // material over the problem's own sigma of it (1 without a jackknife).
  double lamp_sigma_scale = 1;
};
inline constexpr size_t kMinJackknifeViews = 4;

// Whether the capture states how well the light's position is known (Light::position_sigma_m).
inline bool position_sigma_stated(const Light& l) {
  return l.position_sigma_m.x > 0 || l.position_sigma_m.y > 0 || l.position_sigma_m.z > 0;
}

// A lamp whose capture states no sigma is taken as placed to within this (metres), as a tape
// measure places it (docs/formats.md, a shoot's position_sigma_m).
inline constexpr double kUnstatedLampSigmaM = 0.02;
// A lamp the highlight moves more than this many of its stated sigmas from where the capture puts
// it was likely written wrong: it is named, and solved again with its prior this many times wider.
inline constexpr double kLampMovedSigmas = 5;
inline constexpr double kReleasedPriorScale = 10;
// Pixels of each view in the problem, spread over its usable pixels.
inline constexpr size_t kHighlightPixelsPerView = 3000;

// The joint problem for the set's views with one point lamp (inverse-square falloff), started from
// `start` (a line model fit of the set, without optional terms), each pixel's residual weighted by
// 1 / pixel_sigma (the plain fit's residual sigma) with Huber's loss at 3. `threads`: Ceres'.
// `keep`, given, is asked once the lamps are placed (found and moved_sigmas set), before the
// jackknife and the covariance: a reason not to use them ends the work there (HighlightLamps::
// skipped).
using KeepLamps = std::function<std::string(const HighlightLamps&)>;
HighlightLamps lamps_from_highlight(const CaptureSet& set, const Material& start,
                                    double pixel_sigma, int threads, const KeepLamps& keep = {});

}  // namespace aniso::fitting
