// The material as glTF 2.0 metallic-roughness plus KHR_materials_anisotropy, fitted numerically:
// the anisotropic GGX lobe (Burley's D, height-correlated Smith visibility, as the extension
// defines them) whose shape best matches the model's specular lobe k_s S <N,L> over a fixed grid
// of light and view directions (least squares, scale solved in closed form), and the base colour
// and metallic that best match the whole model. The remaining errors are measured, not assumed.
//
// Directions: glTF's anisotropy direction is the one along which roughness grows. A fiber
// reflects like a cylinder: its highlight spreads across the fiber, so that direction is psi + 90
// degrees, and the roughness along the fiber is the base roughness.
#pragma once
#include <string>
#include <vector>

#include "models/material.h"

namespace aniso {

struct GltfPbr {
  double roughness = 1, strength = 0;  // roughnessFactor, anisotropyStrength
  double rotation_rad = 0;             // anisotropyRotation: psi + 90 deg, in [0, pi)
  double metallic = 1;
  RGB base_color{1, 1, 1};
  // KHR_materials_specular: a dielectric whose specular colour is the model's k_s (F0 = 0.04 *
  // specularColorFactor, specularFactor 1), beside a base colour from k_d. False: F0 is glTF's
  // plain 0.04 (a dielectric) or the base colour (a metal).
  bool specular = false;
  RGB specular_color{1, 1, 1};  // specularColorFactor
  // Relative RMS errors over the direction grid: the GGX lobe's shape against k_s S <N,L>, and
  // the whole glTF BRDF against the whole model (both with <N,L>).
  double lobe_rel_rms = 0, total_rel_rms = 0;
  double other_rel_rms = 0;  // the total error of the mapping not chosen (metal vs dielectric)
  std::string mapping;       // what was chosen and why
  size_t samples = 0;        // (L, V) pairs
};

GltfPbr fit_gltf_pbr(const Material& m);

// The same per texel of a line-model material with maps (k_d, k_s, n, the fiber direction), on a
// w x h grid over uv (texel centres, as docs/formats.md's maps): what fit_gltf_pbr gives for the
// material at each texel's centre, the lobe's shape (roughness, strength, its scale) fitted at
// nodes of log n spaced at most 15 % apart and interpolated between them, the colours and the
// metal / dielectric choice per texel from sums over the direction grid (the model is linear in
// k_d and k_s). Linear values; 3 per texel for the base colour.
struct GltfPbrTexels {
  int w = 0, h = 0;
  std::vector<float> base_color, metallic, roughness, strength, rotation_rad;
  // One mapping for every texel (the one with the least whole-model error over them all), so that
  // neighbouring texels never flip between metal and dielectric. With KHR_materials_specular,
  // each texel's specular colour (F0 / 0.04, linear; 3 per texel).
  std::string mapping;
  bool specular = false;
  std::vector<float> specular_color;
  int n_nodes = 0;                 // the lobe fits made
  double worst_total_rel_rms = 0;  // the whole model's worst relative RMS over the texels
};
GltfPbrTexels fit_gltf_pbr_texels(const Material& m, int w, int h);

// The extension's lobe (D * Vis * <N,L>, F = 1) for unit vectors in the frame (u along the
// fiber, w across it, n the normal), alpha_t across the fiber and alpha_b along it.
double ggx_aniso_lobe(double lu, double lw, double ln, double vu, double vw, double vn,
                      double alpha_t, double alpha_b);

}  // namespace aniso
