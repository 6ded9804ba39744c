// Finding the lamps of a photo shoot (docs/photo-shoot.md): a lamp's position as a
// person writes it is a tape measurement (position_sigma_m, 2 cm unless stated) and its radiant
// intensity is rarely known. The board's white paper is a Lambertian reference in every photo:
// its shading, rho / pi * I * h / r^3 at a board point r metres from a lamp h metres above the
// board, gives the lamp's place and intensity. Each photo's point lamps get both from the paper
// between the markers (a maximum a posteriori fit with the written position as the prior; several
// lamps together, their shadings summed), with the position's sigma; I is absolute where the
// paper's reflectance is known (given, or from a grey card) and relative to an assumed paper
// otherwise.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/vec.h"
#include "models/light.h"
#include "photo/shoot/board.h"
#include "photo/shoot/shoot.h"

namespace aniso {

// A point of the board's white paper seen in one photo: board metres and its linear RGB.
struct PaperSample {
  double x = 0, y = 0;
  float rgb[3] = {0, 0, 0};
  float u = 0, v = 0;  // its pixel in the photo
};

// Where a board point of white paper lies: the paper ring between each marker and its square,
// sampled along the ring's centre line, tested against the board as drawn. Computed once per
// shoot (the board's rendering is the expensive part).
class PaperPoints {
 public:
  // Points keep_away_m from the sample's outline `polygon` and from the grey card's `card` (empty
  // where the shoot has none).
  PaperPoints(const BoardSpec& b, const std::vector<std::array<double, 2>>& polygon,
              double keep_away_m, const std::vector<std::array<double, 2>>& card = {});
  // Board points with the lattice cell (i, j) that holds each, as pairs (point, cell).
  struct Point {
    double x, y;
    int i, j;
    double clear;  // metres of white paper all round it
  };
  const std::vector<Point>& points() const { return points_; }

 private:
  std::vector<Point> points_;
};

// The paper samples of one photo: each point's pixel through the homography of its own cell's
// four detected corners (the lens bends a cell by far less than a pixel), its RGB interpolated
// from the merged image; points in a cell not fully detected, off the image or near a clipped
// pixel are left out, and so are points whose pixels reach the ink: kReachPixels pixels of the
// photo, measured on the board through the cell's homography, must stay on the white paper
// (on a 640x480 shoot the far side of a board seen 50 degrees off its normal has pixels of 2 mm,
// and the ink in them shifted the shading by 1 % and the lamp by 10 mm).
inline constexpr double kReachPixels = 2.0;
std::vector<PaperSample> paper_samples(const BoardSpec& b, const PaperPoints& where,
                                       const std::vector<BoardCorner>& corners, const Image& rgb,
                                       const std::vector<uint8_t>& saturated);

// The grey card's readings in one photo (the shoot's `reference`): board points inside the card
// on a 2 mm grid, each through a homography fitted to the detected corners nearest the card (the
// markers it covers have none), kept where the card stays under the pixel's reach with a margin of
// 3 mm and twice that homography's worst corner error; clipped pixels left out.
std::vector<PaperSample> card_samples(const BoardSpec& b,
                                      const std::vector<std::array<double, 2>>& card,
                                      const std::vector<BoardCorner>& corners, const Image& rgb,
                                      const std::vector<uint8_t>& saturated);

// The paper's reflectance taken where the shoot gives no reference: office paper reflects 0.8 to
// 0.9 of visible light.
inline constexpr double kAssumedPaperReflectance = 0.85;

struct LampFound {
  bool solved = false;
  std::string why;  // why it was not (kept as written)
  Vec3 written, found;
  std::array<double, 3> sigma_m{};  // of the found position, per board axis
  double prior_sigma_m = 0.02;
  RGB written_intensity{1, 1, 1}, found_intensity{1, 1, 1};
  double paper_rms = 0;  // relative RMS of the paper's shading about the fit (robust)
  size_t points = 0;
  double moved_sigmas = 0;  // |found - written| in sigma of the written position
  // The paper alone, and how far the written position is from it: the Mahalanobis distance under
  // the paper's covariance and the written sigma together. Beyond kDisagreeSigmas the written
  // position is not taken as a measurement of the lamp and the paper alone places it.
  Vec3 alone;
  double disagreement = 0;
  std::vector<int> agrees_with;  // the alternatives (find_lamp) the paper alone agrees with
  // The grey card under the found lamp: rho_card I / pi per channel by least squares over its
  // points (card_points 0: no card, or too little of it in view), and its relative spread.
  std::array<double, 3> card_amplitude{};
  size_t card_points = 0;
  double card_rms = 0;
  // rho_paper I / pi per channel as the paper's shading gave it.
  std::array<double, 3> paper_amplitude{};
};
inline constexpr double kDisagreeSigmas = 5;

// The lamp of one photo from its paper samples; `light` as written, `rho` the paper's reflectance
// per channel. Needs a point lamp (no attenuation other than the inverse square) and enough paper:
// otherwise returns solved = false and why. `alternatives`: other readings of the written
// position (measured from another edge) to test against the paper alone.
LampFound find_lamp(const std::vector<PaperSample>& paper, const Light& light, double sigma_m,
                    const RGB& rho, double sample_height_m,
                    const std::vector<Vec3>& alternatives = {});

// Several point lamps of one photo from its paper, whose shading is their sum: every lamp's
// position and rho I fitted together, each written position a prior of its sigma (the paper alone
// cannot tell two lamps apart). Each found lamp's `alone` is its found position and its
// `disagreement` how far it moved in written sigmas.
std::vector<LampFound> find_lamps_together(const std::vector<PaperSample>& paper,
                                           const std::vector<Light>& lights,
                                           const std::vector<double>& sigma_m, const RGB& rho,
                                           double sample_height_m);

// Reads the grey card's samples under a photo's found lamps: the card reads c times the paper's
// shading under them (c = rho_card / rho_paper), fitted by least squares, kept on the first lamp
// (card_amplitude = c times its paper amplitude, card_points, card_rms) where there are at least
// kMinCardPoints points whose spread about it is under 10 % (a card lying flat and evenly lit);
// otherwise card_points stays 0.
inline constexpr size_t kMinCardPoints = 30;
void read_card(const std::vector<PaperSample>& card, std::vector<LampFound>* lamps);

// The paper's reflectance from the grey card: per photo, rho_card * (paper amplitude / card
// amplitude) under the same lamp; their median over the photos, its sigma from their spread
// (1.4826 MAD / sqrt(n)). Found where at least one photo saw the card.
struct PaperFromCard {
  bool found = false;
  RGB paper{0, 0, 0}, sigma{0, 0, 0};
  size_t photos = 0, points = 0;
};
PaperFromCard paper_from_card(const std::vector<const LampFound*>& lamps, const RGB& card_rho);

// The lens's vignetting, shared by every photo of the shoot (one camera at one setting): an image
// reads V(r) times what the scene sends, V(r) = 1 + a1 r^2 + a2 r^4, r a pixel's distance from
// the principal point (where the lens's axis meets the image) over the image's half diagonal.
// Within one photo a falloff from the frame's centre looks much like a lamp's own falloff, and a
// lamp placed from the paper alone takes it up (8 % over the board put lamps 16 cm off); over many
// photos, each with its written lamp as a measurement, the board's paper is seen at different
// places of the frame under lamps from different sides, and V is what they share. So a1, a2 are
// fitted with every photo's lamp position and rho I, the written positions as priors of their
// position_sigma_m; a photo whose lamp the paper then puts more than kDisagreeSigmas from where it
// is written (a tape measured from the wrong edge) has its prior dropped and the fit runs again.
// The priors are the written positions times one common scale k, fitted too: a wrong board.square_m
// scales the board frame, and every lamp with it, which V must not take up.
struct Vignetting {
  double a1 = 0, a2 = 0;
  double sigma_a1 = 0, sigma_a2 = 0;
  double cx = 0, cy = 0, half_diagonal = 1;  // pixels
  size_t photos = 0, points = 0;
  double r_max = 0;  // the largest r the paper reached
  bool found = false;
  // V at r_max differs from 1 by more than kVignettingSigmas of its own sigma: only then is it
  // taken out. A lamp found from the paper moves several millimetres for a falloff of 0.3 % over
  // the board, so an estimate of V that its noise does not tell from 1 is not used.
  bool applied = false;
  double sigma_edge = 0;  // the sigma of V at r_max
  // The written positions' common scale k and its sigma, over scaled_lamps lamps (0: none).
  double scale = 1, sigma_scale = 0;
  size_t scaled_lamps = 0;
  double at(double u, double v) const {
    const double r2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) / (half_diagonal * half_diagonal);
    return std::max(1 + a1 * r2 + a2 * r2 * r2, 0.05);
  }
};
inline constexpr double kVignettingSigmas = 3;
// `paper[i]` the paper samples of photo i (empty: none), `lights[i]` its one point lamp as written
// (nullptr: none to find) and `sigma_m[i]` how well it was measured. Found where at least 3 photos
// with a lamp reach r of 0.5 between them.
Vignetting fit_vignetting(const std::vector<std::vector<PaperSample>>& paper,
                          const std::vector<const Light*>& lights,
                          const std::vector<double>& sigma_m, double sample_height_m,
                          const Intrinsics& camera);
// The samples' readings divided by V at their pixels.
void correct_vignetting(const Vignetting& v, std::vector<PaperSample>* samples);

}  // namespace aniso
