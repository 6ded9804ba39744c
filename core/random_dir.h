// A seeded random direction for measuring a lookup's error against the full model.
#pragma once
#include <cmath>
#include <random>

#include "core/local_dir.h"

namespace aniso {

// A direction uniform over the upper hemisphere (n >= 0) of the local frame: three normal draws
// (u, w, |n|, in that order) normalised.
inline LocalDir random_upper_dir(std::mt19937_64& rng, std::normal_distribution<double>& g) {
  const double x = g(rng), y = g(rng), z = std::abs(g(rng)), l = std::sqrt(x * x + y * y + z * z);
  return LocalDir{x / l, y / l, z / l};
}

}  // namespace aniso
