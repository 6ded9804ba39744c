// Light from an environment for the fiber model (docs/models.md §5, ours): the environment
// prefiltered through the fiber model's baked form (render/bake/bake.h),
//   D = s_L G(phi_l, phi_v, s),   S = S_line(a, b) F(phi_l, phi_v, s, kappa),
// where phi_l, phi_v are the angles of the projected L and V from N toward B in the fiber's
// cross-section. For one fiber T the directions L lie at an angle chi round T (chi measured from
// e1 toward e2, render/bake/environment.h chi_frame) and phi_l = chi_N - chi, chi_N the normal's
// angle. So with G and F written as Fourier series in phi_l (zero where the light is below the
// surface), the reflected radiance is a sum over orders k of
//   (coefficients of G or F at phi_v)  x  (integrals over the environment of E s_L or E S_line
//   times cos(k chi) and sin(k chi))
// turned by k chi_N. The integrals are tables over T (and b = <V,T> for S, and n with a map of n);
// the coefficients are a small table over (phi_v, b), the topology s and n. F depends on L also
// through kappa;
// the coefficients take kappa where S_line peaks (a = -b: kappa = 2 (1 - b^2)). What that, the
// series' truncation and the tables' resolution leave is measured against brute force
// (aniso preview --env checks it).
#pragma once
#include <vector>

#include "core/vec.h"
#include "render/bake/bake.h"
#include "render/bake/environment.h"

namespace aniso {

struct FiberEnvironmentTables {
  int order = 0;  // Fourier orders 0..order in chi; terms = 2 order + 1
  int w = 0, h = 0, nb = 0, nphi = 0;
  // Levels of the topology s: one at the material's s where it has one for the whole surface,
  // else the fiber tables' (s = k / (ns - 1)).
  int ns = 1;
  // Levels of n: one at the material's n, or with a map of n levels spaced log_step in log n from
  // logn0 over its range (at most 0.2 apart, bake.h bake_specular_stack): S_line and F at each.
  int nn = 1;
  double logn0 = 0, log_step = 0;
  // Term t: 1 (t = 0), cos(k chi) (t = 2k - 1), sin(k chi) (t = 2k).
  int terms() const { return 2 * order + 1; }
  // Integrals of E s_L basis_t over the environment per T (equirectangular, as
  // EnvironmentTables): (t * h + y) * w + x, RGB.
  std::vector<float> diffuse;
  // Integrals of E S_line(a, b) basis_t per T, level of b (acos(-b) = pi i / (nb - 1)) and level
  // kn of n: (((kn * terms() + t) * nb + i) * h + y) * w + x, RGB.
  std::vector<float> specular;
  // The Fourier coefficients in phi_l of F (terms() values, then those of G: 2 terms() in all) at
  // phi_v = -90 + 180 j / (nphi - 1) degrees, level i of b, level k of s and level kn of n:
  // (((kn * ns + k) * nb + i) * nphi + j) * 2 terms() + q.
  std::vector<float> coef;
  int env_w = 0, env_h = 0;
  double seconds = 0;
  // The coefficients' layers at one level of s, three to a layer (fiber_environment_coef_volume).
  int coef_layers() const { return (2 * terms() + 2) / 3; }
};

// The tables of fiber material `m` (environment_unsupported says which qualify) from its line
// tables and fiber factor tables.
FiberEnvironmentTables prefilter_fiber_environment(const Environment& env, const Material& m,
                                                   const BakeTables& line,
                                                   const FiberBakeTables& fb, int order = 6,
                                                   int w = 64, int h = 32, int nb = 32,
                                                   int nphi = 33, int env_w = 64, int env_h = 32);

// S's terms as the shader's volume reads them (aniso_environment_fiber.glsl): w x (h * nn) texels
// (the levels of n one above the other: a volume's depth stays under the 2048 layers graphics
// hardware holds), terms() * nb layers (term t's level i of b at t * nb + i), RGB.
std::vector<float> fiber_environment_specular_volume(const FiberEnvironmentTables& t);

// The coefficients as the shader's volume reads them (aniso_environment_fiber.glsl): nphi x nb
// texels, coef_layers() * ns * nn layers (level k of s's layers after level k - 1's, each level of
// n's after the one before), RGB holding three coefficients, F's then G's (0 past the last).
std::vector<float> fiber_environment_coef_volume(const FiberEnvironmentTables& t);

// The weights of a coefficient pair (c on cos(k phi_l), s on sin(k phi_l)) on the integrals with
// cos(k chi) and sin(k chi), at the normal's angle chi_N (phi_l = chi_N - chi).
inline void fiber_environment_turn(double c, double s, double cos_k_chi_n, double sin_k_chi_n,
                                   double* on_cos, double* on_sin) {
  *on_cos = c * cos_k_chi_n + s * sin_k_chi_n;
  *on_sin = c * sin_k_chi_n - s * cos_k_chi_n;
}

// What the shader computes (render/shaders/env_fiber.frag) at a node of the tables: the T of cell
// (x, y), level i of b, phi_v at node j, level k of s, the normal at angle chi_n round T; radiance
// k_d D + k_s S.
void fiber_environment_at_node(const FiberEnvironmentTables& t, const Material& m, int x, int y,
                               int i, int j, int k, double chi_n, double out[3]);

}  // namespace aniso
