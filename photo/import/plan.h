// Planning a photo shoot (aniso plan): where to hold the lamp for each camera position of a ring
// round the board so that the sample shows its highlight, and how well a shoot (planned, or
// imported) covers the lobe.
//
// A fiber's highlight lies where the light and view make equal angles with it on opposite sides:
// L.T = -V.T (the reflection cone about the fiber direction T; the mirror direction of V is on
// it). How far a sample point is from its highlight is x = L.T + V.T: 0 on it, and the line
// model's specular term falls off with |x| at a rate set by n. A fit determines the fiber
// direction from highlights seen from many azimuths and n from points at several |x| beside
// them; the plan counts both.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "core/vec.h"
#include "io/formats/capture.h"
#include "photo/shoot/shoot.h"

namespace aniso {

struct PlanOptions {
  int ring = 12;              // camera positions, evenly round the board
  double elevation_deg = 55;  // the camera's angle above the board
  double camera_m = 0.5;      // camera distance from the sample's centre
  double lamp_m = 0.6;        // lamp distance from the sample's centre
  double fiber_deg = 0;       // the fiber direction psi from the sample's tangent
  bool fiber_given = false;   // false: psi 0 assumed (the tangent is the fiber direction)
};

// One photo of the ring: where the camera is and where the lamp goes (the mirror direction of the
// camera about the board's normal at the sample's centre, lamp_m away; on the reflection cone
// of every fiber direction, so the highlight falls on the sample whatever psi is).
struct PlannedPhoto {
  double azimuth_deg = 0;
  Vec3 camera, lamp;
};
std::vector<PlannedPhoto> plan_ring(const Shoot& s, const PlanOptions& o);

// The lobe's coverage over the sample (a grid of points inside its outline) in each photo.
struct Coverage {
  // |x| = |L.T + V.T| over every (photo, point): how many fall in each band.
  static constexpr int kBands = 5;
  static constexpr double kBandEdges[kBands + 1] = {0, 0.03, 0.1, 0.25, 0.5, 2.0};
  std::array<size_t, kBands> band{};
  size_t samples = 0;
  // Per photo: the fraction of the sample's points within its highlight (|x| < kBandEdges[1]),
  // and the camera's azimuth about the sample from the fiber direction (degrees, [0, 360)).
  std::vector<double> highlight_fraction, azimuth_deg;
  // Sectors of 45 degrees of camera azimuth (from the fiber direction, folded: a fiber looks the
  // same from opposite sides) with at least one photo showing the highlight on the sample.
  std::array<int, 4> sectors{};
  std::vector<std::string> missing;  // what the shoot lacks, each with what to do
};

// Photos as (camera position, lamp positions) in the board frame.
struct PlanPhoto {
  Vec3 camera;
  std::vector<Vec3> lamps;
};
// `noun` names a photo in the messages ("photo", "view").
Coverage lobe_coverage(const Shoot& s, const std::vector<PlanPhoto>& photos, const PlanOptions& o,
                       const std::string& noun = "photo");

// The photos of an imported capture (its cameras and point lamps), or of a shoot's ring plan.
std::vector<PlanPhoto> photos_of(const CaptureSet& set);
std::vector<PlanPhoto> photos_of(const std::vector<PlannedPhoto>& ring);

}  // namespace aniso
