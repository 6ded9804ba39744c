// fit/ maps: what a maps material's scalar values are (docs/formats.md "Material maps": the scalar
// keys stay, as mean values): the means of the determined texels, with the sigma of each mean.
#pragma once
#include <cstddef>

#include "fit/types/fit_types.h"

namespace aniso {

struct MapsMeans {
  size_t texels = 0;  // determined texels averaged (0: none; the global values stand)
  double kd[3] = {}, ks[3] = {}, n = 0, psi_deg = 0, s = 0;
  // The sigma of each mean from the texels' own sigmas, taken as independent:
  // sqrt(sum sigma_t^2) / texels.
  double kd_sigma[3] = {}, ks_sigma[3] = {}, n_sigma = 0, psi_sigma_deg = 0, s_sigma = 0;
  bool has_s = false;  // the maps hold s per texel (maps.s; not a topology map's amplitude)
};

// Arithmetic means of k_d, k_s, n (and s) over the determined texels; psi as the mean direction
// of the doubled angle (psi and psi + 180 deg are one direction), in [0, 180).
MapsMeans maps_means(const TexelMaps& m);

}  // namespace aniso
