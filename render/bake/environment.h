// Light from an environment for the line-lighting model (docs/models.md §5; after Heidrich &
// Seidel 1999, "Realistic, hardware-accelerated shading and lighting"): an equirectangular HDR
// environment prefiltered once per material into tables a shader reads per fragment.
//
// The reflected radiance at a point with normal N, fiber T and viewer V is
//   L_o = sum over environment directions L of  L_env(L) dOmega (k_d D + k_s S)(L.T, V.T) <N,L>^+ .
// For one T, the directions L with L.T = a lie on a circle round T at angle chi, and
// <N,L> = sqrt(1 - a^2) cos(chi - chi_N) since N is perpendicular to T. The tables hold, per T
// (equirectangular over the sphere) and b = V.T, the first five Fourier terms in chi of everything
// but the clamp; the clamped cosine max(cos x, 0) = 1/pi + cos(x)/2 + 2 cos(2x)/(3 pi) - ... is
// applied in the shader at the fragment's chi_N. What the truncation and the tables' resolution
// leave is measured against brute force (aniso preview --env; --env-check on large frames).
#pragma once
#include <string>
#include <vector>

#include "core/image.h"
#include "core/vec.h"
#include "render/bake/bake.h"

namespace aniso {

// An equirectangular environment, z up: column x at azimuth phi = 2 pi (x + 1/2) / W from +x
// toward +y, row y at polar angle theta = pi (y + 1/2) / H from +z. Linear RGB radiance.
struct Environment {
  Image radiance;
  std::string name;  // the file, or "studio"
};

// Reads FILE.exr (or any image aniso reads) as an environment: twice as wide as high, three
// channels, finite values >= 0; the error names the file and what is wrong.
Environment read_environment(const std::string& path);

// "studio" (the built-in one below) or a file read as above: what --env names.
Environment named_environment(const std::string& name);

// The built-in studio: a dim grey room (0.02), a soft overhead key (a disc of 25 degrees of
// radiance 4), a warm fill to one side and a cool rim behind, a darker floor (128 x 64).
Environment studio_environment();

// The directions of an environment averaged down to w x h cells: each cell's direction and its
// radiance times solid angle (what a sum over the sphere weights it by).
struct EnvironmentSamples {
  std::vector<Vec3> dir;
  std::vector<RGB> weight;  // L_env dOmega
};
EnvironmentSamples environment_samples(const Environment& env, int w, int h);

// The prefiltered tables of a line material under an environment: nb levels of b = V.T (texel i
// at acos(-b) = pi i / (nb - 1), as the line tables' index), each a w x h equirectangular map over
// T; seven RGB terms, the shader's radiance being
//   t0 + cos(chi) t1 + sin(chi) t2 + cos(2 chi) t3 + sin(2 chi) t4 + cos(4 chi) t5 + sin(4 chi) t6
// with chi_N measured from e1 = normalize(z x T) (x x T where T is within 1e-6 of z) toward
// e2 = T x e1.
struct EnvironmentTables {
  int w = 0, h = 0, nb = 0;
  std::vector<float> terms[7];  // each (level * h + y) * w + x, RGB
  int env_w = 0, env_h = 0;     // the environment cells summed over
  double seconds = 0;
};
EnvironmentTables prefilter_environment(const Environment& env, const BakeTables& tables,
                                        int w = 64, int h = 32, int nb = 32, int env_w = 64,
                                        int env_h = 32);

// What of `m` the prefilters do not cover ("a second fiber with a map of the fiber direction"),
// null where they cover all of it: the line model (its maps of k_d, k_s, n and the fiber direction
// through prefilter_environment_parts), the fiber model with any topology and the same maps
// (render/bake/environment_fiber.h), a second fiber (the same tables at T2) and an isotropic term
// (prefilter_isotropic_environment).
const char* environment_unsupported(const Material& m);

// A material with maps of k_d or k_s: the environment prefiltered through D alone (k_d 1, k_s 0)
// and through S alone (k_d 0, k_s 1), grey, each as prefilter_environment's terms; a fragment's
// radiance is k_d times the first's sum plus k_s times the second's, its maps' values applied
// there (render/shaders/env.frag). With a map of n (`with_n`: the material), S's terms also at
// levels of n spaced evenly in log n over the map's range, at most 0.2 apart (bake.h
// bake_specular_stack): the shader blends the two levels either side of its fragment's log n.
struct EnvironmentParts {
  EnvironmentTables diffuse;
  // S's terms at the material's n; with a map of n, its levels instead (specular then holds only
  // their prefilter's seconds).
  EnvironmentTables specular;
  std::vector<EnvironmentTables> specular_n;
  double logn0 = 0, log_step = 0;
};
EnvironmentParts prefilter_environment_parts(const Environment& env, const BakeTables& tables,
                                             const Material* with_n = nullptr);
// The parts as the volumes aniso_environment_parts.glsl reads, RGB: D's w x h x (7 nb) (term t's
// level i of b at layer t * nb + i) and S's w x (h * levels of n) x (7 nb) (the levels of n one
// above the other).
std::vector<float> environment_parts_d_volume(const EnvironmentParts& p);
std::vector<float> environment_parts_s_volume(const EnvironmentParts& p);

// The isotropic term (docs/models.md §3: k_d,iso <N,L>^+ + k_s,iso (<N,H>^+)^n_iso) under an
// environment: two equirectangular tables, the irradiance over the normal N (the sum of L_env
// <N,L>^+ dOmega, exact) and the Blinn-Phong lobe as a Phong lobe over the mirror direction R of V
// (the sum of L_env (<R,L>^+)^(n_iso / 4) dOmega: round its peak the angle between L and R is twice
// that between H and N), times a factor over <N,V> that makes it exact for a uniform environment:
// the Blinn-Phong lobe's integral over the lit hemisphere over the Phong lobe's over the sphere.
// What remains is measured against brute force (aniso preview --env).
struct IsotropicEnvironment {
  int w = 0, h = 0;
  std::vector<float> irradiance, glossy;  // (y * w + x) * 3, RGB
  static constexpr int kScaleNodes = 33;  // <N,V> = i / 32
  float scale[kScaleNodes] = {};
  double seconds = 0;
};
IsotropicEnvironment prefilter_isotropic_environment(const Environment& env, double n_iso,
                                                     int w = 64, int h = 32, int env_w = 128,
                                                     int env_h = 64);

// The direction of equirectangular cell (x, y) of a w x h map (the convention of Environment).
Vec3 cell_direction(int x, int y, int w, int h);

// The frame round T the tables use for chi.
void chi_frame(const Vec3& T, Vec3* e1, Vec3* e2);

}  // namespace aniso
