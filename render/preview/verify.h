// `aniso verify`: renders every view of a capture set with a material (the same shading the
// simulator uses, from the set's geometry buffers, without shadow rays) and reports the error
// against the captured images, per view and overall.
#pragma once
#include <cmath>
#include <string>
#include <vector>

#include "core/local_dir.h"
#include "io/formats/capture.h"
#include "models/material.h"

namespace aniso {

struct ViewError {
  size_t pixels = 0;
  double rms = 0, max_abs = 0, mean_signal = 0;
  // Pixels that read under a quarter of what the material predicts, short of it by more than 5
  // sigma of the view's noise (robust, from its residuals), where it predicts at least a tenth of
  // the view's mean: a cast shadow or an occluder (verify traces no shadow rays), or a material
  // that does not describe them; and the RMS of the other pixels.
  size_t dark = 0;
  double rms_without_dark = 0;
  // The image's own noise (one channel's sigma, robust, from second differences of neighbouring
  // sample pixels: what a perfect model would leave), and the RMS against it.
  double noise = 0;
  double rel_rms() const { return mean_signal > 0 ? rms / mean_signal : 0; }
  double rms_over_noise() const { return noise > 0 ? rms / noise : 0; }
};
// "at the noise" (RMS at most 1.5 times it), "near the noise" (at most 3), "misfit" (more).
const char* verdict(double rms_over_noise);

struct VerifyResult {
  std::vector<ViewError> views;
  ViewError overall;
  size_t light_evals = 0;
};

// What `aniso report` draws of a capture against a material, gathered in verify's pass.
struct VerifySamples {
  // Normalised residuals (model minus image, green, over the view's noise) in kBins bins of
  // kStep from kLow, and how many fell below and above them.
  static constexpr int kBins = 40;
  static constexpr double kLow = -5, kStep = 0.25;
  std::vector<size_t> histogram = std::vector<size_t>(kBins, 0);
  size_t below = 0, above = 0;
  void add_residual(double r) {
    if (std::isnan(r)) return;
    const double b = (r - kLow) / kStep;
    if (b < 0)
      ++below;
    else if (b >= kBins)
      ++above;
    else
      ++histogram[static_cast<size_t>(b)];
  }
  // Pixels lit by one light, spread evenly over the views up to `max_lobe` of them: the
  // directions in the fiber's frame at the pixel (T the fiber, B = N x T) and the specular part of
  // the green reflectance, the image's (its value less ambient, over the irradiance, less the
  // material's diffuse part) and the model's.
  struct Lobe {
    float lt, vt;  // L.T, V.T
    float ht, hb;  // the half vector's T and B components
    float data, model;
  };
  std::vector<Lobe> lobe;
  size_t max_lobe = 6000;
  // One sample from directions in the surface's local frame and the fiber angle there.
  static Lobe lobe_at(const LocalDir& L, const LocalDir& V, double psi_deg, double data,
                      double model);
  // The green reflectance of material `at` (no maps) at (L, V) and topology s, and of its diffuse
  // part alone (its specular lobes' k_s 0): what a lobe sample subtracts.
  static void reflectance_and_diffuse(const Material& at, const LocalDir& L, const LocalDir& V,
                                      double s, double* f, double* fd);
  // With a residual folder: also image_NNN.png and model_NNN.png, the view's image and the
  // model's on the sample, sRGB at one exposure per view (the image's 99.5th percentile white).
  bool view_pictures = false;
};

// With `residual_dir`, also writes residual_NNN.exr per view (model - image, RGB; 0 off the
// sample) and residual_NNN.png beside it: the green channel's residual over the view's noise,
// blue at -3 sigma, white at 0, red at +3 sigma; grey off the sample.
VerifyResult verify_capture(const CaptureSet& set, const Material& m,
                            const std::string& residual_dir = "", VerifySamples* samples = nullptr);

}  // namespace aniso
