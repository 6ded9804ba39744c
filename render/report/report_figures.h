// The pictures of `aniso report`, drawn by the tool itself as SVG text (and PNG for the maps'
// sigma): each carries the numbers it shows as data- attributes, so a test reads them back.
#pragma once
#include <string>
#include <vector>

#include "core/image.h"
#include "render/preview/verify.h"

namespace aniso {

// Normalised residuals against the unit Gaussian: bars of the histogram as a density, the
// Gaussian's curve over them; data-std is the residuals' standard deviation within the bins,
// data-within1 the share within one sigma (0.683 for the unit Gaussian).
std::string residual_histogram_svg(const VerifySamples& s);

// The lobe against the data, polar plots in the fiber's frame: one half-disc per band of the
// light's angle to the fiber (up to four, at quartiles of the samples' angles), the angle round
// it the viewer's angle to the fiber (0 along T), the radius the specular part of the reflectance
// on one scale for all (the largest mean of a bin); the data's points, their means and the
// model's means over the same points in bins of 6 degrees, and the mirror cone (where
// V.T = -L.T) dashed. Each panel's g carries data-center (degrees), data-count, data-peak (its
// largest mean) and data-misfit (the RMS of data minus model over the bins, over the scale).
std::string lobe_polar_svg(const std::vector<VerifySamples::Lobe>& lobe);

// The half vectors of those samples in the fiber's frame (H.T right, H.B up) on the unit disc:
// which part of the lobe the capture saw.
std::string half_vector_coverage_svg(const std::vector<VerifySamples::Lobe>& lobe);

// The solver's cost against its accepted steps, on a log scale where it fell tenfold or more
// (data-first, data-last, data-steps).
std::string convergence_svg(const std::vector<double>& cost);

// The fiber map (R = cos 2psi, G = sin 2psi) as a field of short line glyphs, u to the right and v
// down as the map's rows run, at most 40 a side; glyphs of texels the data do not determine
// (`determined` R = 0, if given) pale. data-glyphs counts them.
std::string direction_field_svg(const Image& fiber, const Image* determined);

// The residual pictures' colour bar: blue at -3 sigma of the view's noise, white 0, red +3.
std::string residual_colour_bar_svg();

// A one-channel map (channel 0 of `img`) as a picture: a texel a square of pixels (shorter side at
// least 256), coloured from dark blue through green to yellow over [lo, hi] (on a log scale when
// `log`); *lo and *hi are set from the finite values (positive ones for log). Values past float's
// largest (sigma "not known") are drawn grey.
Image scalar_map_picture(const Image& img, bool log, double* lo, double* hi);

}  // namespace aniso
