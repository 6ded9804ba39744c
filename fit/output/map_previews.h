// fit/ output: small 8-bit PNG pictures of a maps fit for a person, written beside the maps' EXR
// files (fit --maps, merge): what no image viewer shows of the float maps.
#pragma once
#include <string>
#include <vector>

#include "fit/types/fit_types.h"

namespace aniso {

// The pictures' plain names and what each shows: {key, file name}.
struct MapPreview {
  std::string key, file;
};
std::vector<MapPreview> map_preview_files(const std::string& material_path);

// Writes them into `dir` under those names: k_d and k_s in sRGB (k_s scaled to its largest
// texel), n on a log scale from the map's smallest to its largest, the fiber direction as hue
// (the doubled angle once round the colour wheel), each dimmed to a quarter where the texel is not
// determined; a texel a square of pixels so that the picture's shorter side is at least 256.
void write_map_previews(const std::string& material_path, const std::string& dir,
                        const TexelMaps& t, const std::vector<double>& kd,
                        const std::vector<double>& ks, const std::vector<double>& n,
                        const std::vector<double>& psi_deg);

}  // namespace aniso
