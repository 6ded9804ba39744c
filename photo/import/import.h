// aniso import: a photo shoot (docs/formats.md "Photo shoot") to a capture set. Every photo's
// bracket is merged (photo/shoot/merge.h) and the board found in it (photo/shoot/board.h); board
// corners on or near the sample are dropped; the camera is calibrated from the photos when the
// shoot gives none (photo/shoot/calibrate.h); each photo's pose comes from the board; and each
// accepted photo becomes one view: its merged image cropped to the sample, with per-pixel geometry
// of the sample plane (the ray of each distorted pixel meets z = -height_m). A photo whose board is
// not found, or whose reprojection error is poor, is left out with the reason, and the rest go on.
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/vec.h"
#include "io/images/exr_compression.h"
#include "photo/lamps/lamps.h"
#include "photo/shoot/raw.h"
#include "photo/shoot/shoot.h"

namespace aniso {

class ProgressSink;  // core/progress.h

struct ImportOptions {
  double max_rms_px = 1.0;         // photos whose corners reproject worse are left out
  double sample_margin_m = 0.003;  // corners this close to the sample's outline are dropped too
  int min_corners = 8;             // fewer corners found: the photo is left out
  bool overlays = true;            // overlays/NNN.png for every photo
  const ProgressSink* progress = nullptr;             // core/progress.h; null: silent
  ExrCompression compression = ExrCompression::kZip;  // the views' images and geometry buffers
  bool verbose = true;                                // one line per photo on stdout
  // The whole import's memory: photos are merged as many at once as fit in it beside what every
  // photo keeps between the passes; a shoot that does not fit is refused before any decoding.
  double memory_mb = 4096;
  // At most this many photos calibrate the camera (spread over the shoot; the calibration's cost
  // grows as the cube of its photos); every other photo is posed against it.
  int calibrate_on = 40;
  // Each photo's lamp found from the board's paper (photo/lamps/lamps.h); false: taken as written.
  bool find_lamps = true;
  // The lens's vignetting found from the paper (with the lamps) and taken out of the views' images;
  // false: the camera is taken as free of it.
  bool vignetting = true;
  // Who develops RAW files (photo/shoot/raw.h).
  RawDevelop raw_develop = RawDevelop::kStreamed;
};

struct ImportedPhoto {
  std::vector<std::string> files;
  int markers = 0, corners = 0, corners_dropped = 0;  // dropped: on or near the sample
  double rms_px = -1;                                 // -1: no pose
  double tilt_deg = 0;                                // board normal against the optical axis
  Mat4 world_from_camera;
  bool accepted = false;
  std::string reason;  // why it was left out
  size_t saturated_pixels = 0, sample_pixels = 0;
  int view = -1;  // index in the capture set
  bool decoded_twice = false;
  std::vector<LampFound> lamps;  // per light: as written and as the paper found it
  std::vector<RawInfo> raw;  // per RAW image of the bracket  // the sample fell outside the region
                             // kept from the first pass
};

struct ImportResult {
  Intrinsics camera;
  bool calibrated = false;
  double calibration_rms_px = 0;
  std::array<double, 4> sigma{};  // fx, fy, cx, cy (calibrated only)
  // What the photos left undetermined and the calibration held instead, each with why.
  std::vector<std::string> held;
  std::vector<std::string> warnings;  // what the shoot as written gets wrong (lamps)
  PaperFromCard card;                 // the paper's reflectance from the grey card (reference)
  Vignetting vignetting;              // the lens's, as found from the paper
  std::string intensities;            // how the lamps' intensities are known (intensity_note)
  std::vector<ImportedPhoto> photos;
  size_t views = 0;
  size_t calibrated_on = 0;  // photos the calibration used (the rest posed against it)
  int merge_threads = 0;     // photos merged at once (memory_mb)
  // What memory_mb leaves beside the merges for the merged regions around the samples kept
  // between the passes; a photo whose region did not fit is decoded again (decoded_twice).
  double crop_budget_mb = 0;
  double memory_estimate_mb = 0;  // the merges' and overlays' planned peak (crops beside it)
  double seconds = 0, seconds_detect = 0, seconds_calibrate = 0, seconds_write = 0;
};

// How the lamps' intensities are known: absolute (from the grey card, or the paper's reflectance
// given) or relative.
std::string intensity_note(const Shoot& s, const ImportResult& r, bool found);

// CAPTURE_DIR/import_report.json's content (photo/import/import_report.cpp).
nlohmann::json import_report_json(const Shoot& s, const ImportResult& r, const ImportOptions& o);

// Imports the shoot into out_dir (a folder output: written whole or not at all).
ImportResult import_shoot(const Shoot& s, const std::string& out_dir, const ImportOptions& o);

}  // namespace aniso
