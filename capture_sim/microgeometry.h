// Micro-geometry mode: a virtual gonioreflectometer that measures what the fiber model predicts.
// An actual patch of parallel unit cylinders in the periodic arrangement of docs/models.md §4 (low
// row at (kP, 0), high row at (kP + P/2, 2 sin theta)) is built as Embree round linear curves
// (exact cylinders), lit by a directional light; rays from the viewer hit the fibers, shadow rays
// test the light, and the reflected light is averaged over many rays. Rays are spread uniformly
// over a whole number of periods seen from V, so each hit is weighted by its projected width, which
// is the model's <n,v> dphi weighting.
#pragma once
#include <cstdint>
#include <memory>
#include <string>

#include "models/local_dir.h"

namespace aniso {

class ProgressSink;  // core/progress.h

struct MicroMeasurement {
  double D = 0, S = 0;        // mean <n,L>^+ and (<R,V>^+)^n over visible points, lit only
  double D_se = 0, S_se = 0;  // standard errors of the means
  size_t rays = 0;            // primary + shadow rays cast
};

class MicroPatch {
 public:
  // A patch for topology s: `copies` fibers per row on each side, each `length` long.
  explicit MicroPatch(double s, int copies = 200, double length = 400.0);
  ~MicroPatch();
  MicroPatch(const MicroPatch&) = delete;
  MicroPatch& operator=(const MicroPatch&) = delete;
  // L and V in the fiber frame (u = T, w = B, n = N), both unit and above the surface.
  MicroMeasurement measure(const LocalDir& L, const LocalDir& V, double n, int rays,
                           uint64_t seed) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The agreement sweep: for every topology value and direction pair of a grid, the model's D, S
// next to the measured ones. Written as CSV; the summary gives the worst differences in absolute
// terms and in standard errors.
struct MicroSweepSummary {
  size_t configs = 0, rays = 0;
  double max_dD = 0, max_dS = 0, max_zD = 0, max_zS = 0, seconds = 0;
};
MicroSweepSummary micro_sweep(const std::string& csv_path, double n, int rays, uint64_t seed,
                              const ProgressSink* progress);

}  // namespace aniso
