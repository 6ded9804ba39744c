// A measured BRDF of the RGL material database (EPFL; Dupuy & Jakob 2018, "An Adaptive
// Parameterization for Efficient Material Acquisition and Rendering"): the `.bsdf` tensor file,
// evaluated as the database's own reader (powitacq) does, in single precision as it does. The
// file stores, per incident direction on its (phi_i, theta_i) grid, the measurement warped by the
// visible normal distribution: a 2D grid over the unit square that the inverse VNDF warp of the
// half vector indexes, with the NDF and the projected area sigma beside it:
//
//   f_r cos(theta_o) = rgb(invert_vndf(u(h); phi_i, theta_i); phi_i, theta_i) ndf(u(h)) /
//                      (4 sigma(u(wi)))
//
// with u(theta, phi) = (sqrt(2 theta / pi), (phi + pi) / 2 pi) (phi of h relative to phi_i in an
// isotropic file). Directions: the file's x axis is the sample's reference tangent U, its z axis
// the normal. `wi` is toward the viewer and `wo` toward the light (as Mitsuba calls the reader):
// the value is f_r cos(theta_L), what a sample table holds (docs/measured-brdf.md). The data are
// not reciprocal to the last digit; the roles of the two directions are kept as measured.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "io/formats/table.h"
#include "models/local_dir.h"

namespace aniso {

class RglBsdf {
 public:
  // Reads and checks the file: header, every field's type and shape, offsets inside the file,
  // finite values. Throws an Error naming the file and the field; nothing is allocated beyond
  // what the file's own size holds.
  static RglBsdf read(const std::string& path);

  // f_r cos(theta_L) per RGB channel for light L and view V in the sample's frame (zero below
  // either horizon). Negative values (out-of-gamut spectra) are clamped to 0, as the reader does.
  // A spectral file's spectrum is turned into linear sRGB (spectrum_rgb_weights).
  std::array<float, 3> eval(const LocalDir& L, const LocalDir& V) const;
  // A spectral file's f_r cos(theta_L) at each of its wavelengths, as the database's spectral
  // reader gives it (not clamped); empty for an RGB file.
  std::vector<float> eval_spectrum(const LocalDir& L, const LocalDir& V) const;

  bool isotropic() const { return isotropic_; }
  bool spectral() const { return !wavelengths_.empty(); }
  const std::vector<float>& wavelengths() const { return wavelengths_; }  // nm
  const std::string& description() const { return description_; }
  const std::vector<float>& theta_i() const { return theta_i_; }
  const std::vector<float>& phi_i() const { return phi_i_; }

  // A 2D grid of values over the unit square with bilinear interpolation, optionally one grid
  // per node of D parameters (interpolated linearly between nodes): powitacq's Marginal2D, with
  // the inverse of its sample warp where `cdf` is built.
  struct Grid {
    uint32_t nx = 0, ny = 0;
    std::vector<uint32_t> param_size, param_stride;
    std::vector<std::vector<float>> param_values;
    std::vector<float> data, marginal_cdf, conditional_cdf;
    void build(uint32_t nx, uint32_t ny, const float* values,
               const std::vector<std::vector<float>>& params, bool with_cdf);
    float eval(float x, float y, const float* param) const;
    void invert(float* x, float* y, const float* param) const;

   private:
    struct Weights {
      float w[2 * 3];
      uint32_t slice = 0;
    };
    Weights weights(const float* param) const;
    float lookup(const float* base, uint32_t index, uint32_t size, const Weights& w,
                 size_t dim) const;
  };

 private:
  // The warp's sample position and the scale ndf / (4 sigma) for a light and view (false below
  // either horizon); params: phi_i, theta_i.
  bool locate(const LocalDir& L, const LocalDir& V, float* sx, float* sy, float* scale,
              float params[2]) const;

  Grid ndf_, sigma_, vndf_, rgb_;  // rgb_: the spectra of a spectral file, per wavelength
  bool isotropic_ = true;
  std::vector<float> wavelengths_;
  std::vector<std::array<float, 3>> rgb_weights_;  // per wavelength: its share of R, G and B
  std::string description_;
  std::vector<float> theta_i_, phi_i_;
};

// Linear sRGB from a spectrum sampled at `nm` (increasing): per sample, its weight in R, G and B.
// The CIE 1931 2-degree colour matching functions (the multi-lobe Gaussian fit of Wyman, Sloan
// and Shirley 2013, within about 1 % of the tabulated ones) integrated by the trapezoid rule over
// the samples, XYZ to linear sRGB, each channel scaled so that a flat spectrum of 1 gives RGB
// (1, 1, 1): a reflectance under an equal-energy light, white balanced in RGB. Throws where
// no sample lies in the visible range.
std::vector<std::array<float, 3>> spectrum_rgb_weights(const std::vector<float>& nm);

// The file as a sample table for a fit, on its own grid: each viewer direction of the file's
// (theta_i, phi_i) nodes below 80 degrees (an isotropic file at azimuths 0, 45, 90 and 135
// degrees from U, so that a fit sees whether the lobe turns with the sample), and for each the
// half vectors on the file's NDF grid (u = sqrt(2 theta_h / pi): dense at the lobe, out to the
// diffuse part), the light the mirror of the viewer about each; lights below 85 degrees. Values
// f_r cos(theta_L) as eval gives them.
SampleTable measured_table(const RglBsdf& b);

// Fills a sample table's values from a measured file (light i, view o as the table's columns).
void evaluate_table(const RglBsdf& b, SampleTable* t);

// Whether a path names an RGL material-database file (by its extension).
bool is_rgl_bsdf(const std::string& path);

}  // namespace aniso
