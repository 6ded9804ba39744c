// A simulated photo shoot (aniso synth --photos): a flat sample of a known material lying on a
// printed ChArUco board on a grey table, photographed by a camera with radial distortion from
// many positions, each photo lit by one lamp and taken as a bracket of exposures. Ray traced with
// Embree through the lens model (core/lens.h); the board is box-filtered over each pixel's
// footprint so its corners land where a real lens would put them. Writes what a person would
// have: shoot.json (docs/formats.md "Photo shoot") and the photos, plus truth.json and
// material.json (intrinsics, distortion, every pose, the material) for checking `aniso import`.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "models/material.h"
#include "photo/shoot/board.h"

namespace aniso {

class ProgressSink;  // core/progress.h

struct PhotoShootOptions {
  Material truth;
  BoardSpec board;
  std::vector<std::array<double, 2>> polygon{
      {0.09, 0.09}, {0.21, 0.09}, {0.21, 0.15}, {0.09, 0.15}};
  double height_m = 0.0005;             // the sample is a thin plate on the board
  std::array<double, 2> tangent{1, 0};  // reference tangent U on the board (unit)
  int width = 960, height = 720;
  int photos = 24;
  std::vector<double> bracket{1.0, 0.25, 0.0625};  // exposures of each photo, relative
  double read_noise = 0.002;  // Gaussian sigma in linear units of full scale, before encoding
  bool raw16 = false;         // 16-bit linear PNGs (RAW-like) instead of 8-bit sRGB
  bool dng = false;           // ... or linear DNG files (16-bit; read back through LibRaw)
  bool bayer = false;         // dng: a camera's RGGB mosaic, left for LibRaw to demosaic
  bool jpeg = false;          // ... or 8-bit sRGB JPEGs (quality 95), as a camera writes them
  std::array<double, 5> distortion{-0.08, 0.03, 0, 0, 0};
  uint64_t seed = 1;
  const ProgressSink* progress = nullptr;  // core/progress.h; null: silent
  // How the photographer holds the camera: "upright" (walking round the board, the camera level
  // with the horizon, 40-70 degrees above the board: every photo tilts the board the same way in
  // its frame, as a person's shoot does) or "turned" (the camera turned with the board, as if the
  // board were rotated under a fixed camera; up to 15 degrees of roll).
  std::string walk = "turned";
  // What a person writes of the lamps: each position off by N(0, lamp_error_m) per axis (a tape
  // measure; its own seeded stream), and, with hide_intensity, every intensity as 1 (unknown).
  double lamp_error_m = 0;
  bool hide_intensity = false;
  // "truth": the sample is rendered with its material's own model. "ggx": with an anisotropic GGX
  // microfacet BRDF instead (Trowbridge-Reitz normals, Smith's separable shadowing, Fresnel held
  // at k_s), as another renderer would: roughness along the fibers alpha_t = sqrt(2 / (n + 2)),
  // across them ggx_alpha_b, the diffuse part k_d <N,L>. A model the fit does not have, for
  // checking that its sigma covers its error there.
  std::string brdf = "truth";
  double ggx_alpha_b = 0.5;
  // The printed paper's diffuse reflectance (import assumes 0.85 where the shoot gives none), and a
  // grey card of reflectance grey_card lying on the board over card_m (x0, y0, x1, y1, board
  // metres), written as the shoot's `reference`; 0: no card.
  // A second lamp in every photo: a fill beside the camera, higher, at 0.4 of the key lamp's
  // irradiance (truth.json's fill_lamps).
  bool fill_lamp = false;
  double paper_albedo = 0.85;
  // The lens's vignetting: every pixel reads 1 + vignetting r^2 times the scene's radiance, r its
  // distance from the image's centre over the half diagonal (-0.3: 30 % darker in the corners).
  double vignetting = 0;
  double grey_card = 0;
  std::array<double, 4> card_m{0.015, 0.015, 0.075, 0.065};
};

// The anisotropic GGX reflectance times <N,L> for unit irradiance (PhotoShootOptions::brdf),
// for L and V in the local frame (U, W = N x U, N) of a surface whose fibers lie at psi from U.
void ggx_reflectance(const Material& m, double alpha_b, double Lu, double Lw, double Ln, double Vu,
                     double Vw, double Vn, double out[3]);

struct PhotoShootStats {
  size_t photos = 0, images = 0, primary_rays = 0, shadow_rays = 0, saturated_codes = 0;
  double seconds = 0;
};

// Writes the shoot into out_dir (atomically, as every folder output).
PhotoShootStats simulate_photo_shoot(const PhotoShootOptions& o, const std::string& out_dir);

}  // namespace aniso
