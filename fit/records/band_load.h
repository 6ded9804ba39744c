// fit/ internal: a capture's observations band by band of the maps' texel rows (--maps with
// --global, fit/maps/maps_bands.cpp): one band's records at a time.
#pragma once
#include <cstddef>
#include <memory>
#include <vector>

#include "fit/records/observations.h"
#include "fit/records/pixel_records.h"

namespace aniso::fitting {

// Loads the bands in order, each into the same arrays (their pages touched once, not once per
// band), reading of each view only the rows with a pixel the band keeps; a fixed camera's geometry
// is decoded once for all bands. Every pixel is counted (left out, unlit) by one band, and the
// images' noise comes from every row once: after the last band, the counts added up and the noise
// are those of one load of every pixel.
class BandLoader {
 public:
  BandLoader(const CaptureSet& set, const FitOptions& opt);
  ~BandLoader();
  BandLoader(const BandLoader&) = delete;
  BandLoader& operator=(const BandLoader&) = delete;
  // The bytes of the records one load of every pixel would hold, from view 0's mask (the others
  // taken to be alike; its geometry stays decoded for the bands). With `estimate_only`, from its
  // mask and uv alone (row_bytes still counts): for a caller that loads no band.
  size_t record_bytes(bool estimate_only = false);
  size_t record_pixels() const;  // after record_bytes: the pixels (records) it counted
  // After record_bytes: the records' bytes by texel row of the maps, and the bytes of the pixels
  // views sharing a geometry share (SharedPixels, while a band loads), from every view's mask
  // pixels' uv (a pixel outside [0, 1)^2 counted in row 0; each geometry read once more where views
  // have their own), counted when first asked (a caller that wants the estimate alone pays
  // nothing); empty where a view's geometry is a mesh, traced per view (its rows unknown before the
  // views are traced).
  const std::vector<double>& row_bytes();
  // Of row_bytes, the shared pixels' (0 in rows no view shares; empty where row_bytes is).
  const std::vector<double>& shared_row_bytes();
  void plan(std::vector<UvBand> bands);  // before the first load
  // Band j's observations, in place of the band before's; its counts added to *rep.
  const ObsSet& load(size_t j, FitReport* rep);
  const ObsSet& observations() const;  // the band loaded last
  // What the band loaded last held at its load's end: its records (held_bytes) and the pixels
  // its views shared while they were read (SharedPixels).
  size_t held_bytes() const;
  size_t shared_bytes() const;  // ... of it the shared pixels
  // The images' noise from every band's rows (ObsSet::pixel_noise): after the last band.
  double pixel_noise();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace aniso::fitting
