// Baked lookup textures of the line-lighting model (docs/models.md §5; Heidrich & Seidel §3; the
// OpenGL course notes).
//
// D(a) and S(a, b; n) are tabulated over a = <L,T>, b = <V,T> in [-1, 1]^2 on an N x N grid whose
// first and last texel centres sit exactly on ±1, so grazing (T parallel to L) is sampled, not
// extrapolated. Two indexings, both reached from the paper's texture matrix s = (a + 1) / 2:
//  - cosine (the paper's): texel i at a_i = -1 + 2 i / (N - 1); the shader maps s to the texel
//    centre with u = (s (N - 1) + 0.5) / N, folded into the texture matrix;
//  - angle (default): texel i at acos(-a_i) = pi i / (N - 1); the shader adds one acos. Since
//    s_L s_V - a b = -cos(alpha + beta) with alpha = acos a, beta = acos b, the specular lobe is a
//    band of constant width in angle space, while in cosine space it pinches to nothing at the
//    corners (a, b) = ±(1, -1) where bilinear interpolation then fails: at n = 500 and N = 256 the
//    angle index cuts the worst error several-fold (measured: `aniso bake`, bench bake).
// Diffuse (grey D),
// specular (grey S, depends on n only) and the combined RGB k_d D + k_s S are separate tables so
// colours can change without re-baking. <N,L>^+ is applied per fragment, not baked.
#pragma once
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "models/local_dir.h"
#include "models/material.h"

namespace aniso {

class ProgressSink;  // core/progress.h

enum class BakeIndex { kCosine, kAngle };
const char* index_name(BakeIndex i);
BakeIndex parse_index(const std::string& name);  // "cosine" | "angle"; throws otherwise

struct BakeTables {
  int size = 0;
  BakeIndex index = BakeIndex::kAngle;
  Image diffuse;   // 1 channel: D
  Image specular;  // 1 channel: S
  Image combined;  // 3 channels: k_d D + k_s S
  // Error of bilinear lookup against direct evaluation of k_d D + k_s S, over `samples` random
  // (a, b) pairs (seeded) plus a dense line through the specular peak; max over channels.
  double max_abs_error = 0, rms_error = 0, peak_value = 0;
  size_t samples = 0;
  uint64_t seed = 0;
  double seconds = 0;
};

BakeTables bake_line(const Material& m, int size, BakeIndex index = BakeIndex::kAngle,
                     uint64_t seed = 1);

// The cosine a at texel i, and the continuous texel coordinate in [0, N - 1] of a cosine a.
double texel_cosine(int i, int n, BakeIndex index);
double texel_coord(double a, int n, BakeIndex index);

// Bilinear lookup with the texel-centre convention above (a, b clamped to [-1, 1]).
double lookup_bilinear(const Image& table, double a, double b, int channel, BakeIndex index);

// Largest change between neighbouring texels (along a row or a column, any channel) of a table:
// what GL_LINEAR's 8-bit weights may add to its lookup.
double max_texel_step(const Image& table);

// The fiber model's baked form (ours, docs/models.md §5): the line tables times factors over the
// projected angles. Exactly,
//   D_fiber = D_line(a) * G(phi_l, phi_v, s),          G = (1/W) int_{vis&lit} <n,l><n,v> dphi
//   S_fiber = S_line(a, b) * F(phi_l, phi_v, s, kappa), F = (1/W) int_{vis&lit} (1 - kappa sin^2
//   x)^n <n,v> dphi
// with phi_l, phi_v the angles of the projected L, V from N in the fiber's cross-section,
// x = phi - (phi_l + phi_v)/2 and kappa = 2 s_L s_V / (s_L s_V - ab). So the factorisation is exact
// and only interpolation errs: G is tabulated over (phi_l, phi_v, s), F over (phi_l, phi_v, s, k)
// with k = kappa / (1 + kappa) in [0, 1]. Angles span [-90, 90] deg with texel centres on the ends,
// s spans [0, 1]. The error against the full model is measured at bake time and published.
struct FiberBakeTables {
  int nphi = 64, ns = 9, nk = 16;
  std::vector<float> G;  // index ((is) * nphi + j) * nphi + i   (i: phi_l, j: phi_v)
  std::vector<float> F;  // index (((is) * nk + k) * nphi + j) * nphi + i
  double max_abs_error = 0, rms_error = 0, p99_error = 0, peak_value = 0;
  size_t samples = 0;
  double seconds = 0;
};

FiberBakeTables bake_fiber(const Material& m, const BakeTables& line, int nphi = 64, int ns = 9,
                           int nk = 16, uint64_t seed = 1, const ProgressSink* progress = nullptr);

// What the preview's shader computes, on the CPU: k_d D + k_s S from the baked tables for L, V in
// the fiber frame (u = T, w = B, n = N) at topology s.
void fiber_baked_eval(const Material& m, const BakeTables& line, const FiberBakeTables& fb,
                      const LocalDir& L, const LocalDir& V, double s, double out[3]);

// F's tables at one n, in FiberBakeTables::F's layout (nphi * nphi * ns * nk floats at F).
void bake_fiber_F(double n, int nphi, int ns, int nk, float* F);
// Where L and V (fiber frame) fall in the tables: the line tables' a = <L,T>, b = <V,T>, the
// in-plane angles and kappa (as the shaders' anisoFiberAt); false where either is below the
// surface.
struct FiberCoords {
  double a = 0, b = 0, phi_l = 0, phi_v = 0, kappa = 0;
};
bool fiber_coords(const LocalDir& L, const LocalDir& V, FiberCoords* c);
// G and F at the in-plane angles, topology s and kappa, multi-linear in the tables: G from fb,
// F from `Ftab` in fb.F's layout (fb.F itself, or a level of a FiberStack).
void fiber_factors(const FiberBakeTables& fb, const float* Ftab, double phi_l, double phi_v,
                   double s, double kappa, double* G, double* F);

// The line model's specular table at many n (ours, for materials with a map of n): levels of
// S(a, b; n) at n spaced evenly in log n over the map's range, on the same grid and index as the
// table they stand beside (render/bake/bake.h). The shader takes S bilinearly from the two levels
// either side of its fragment's log n and blends them with its own exact weight; k_d, k_s and the
// fiber direction come from their maps per fragment. The error of that lookup against S itself is
// measured at bake time over random (a, b, n), as bake_line measures its tables.
struct SpecularStack {
  int size = 0, levels = 0;
  BakeIndex index = BakeIndex::kAngle;
  double logn0 = 0, logn1 = 0;  // log n of the first and the last level
  std::vector<Image> S;         // one 1-channel size x size table per level
  // |stack lookup - S| over `samples` random (a, b) at random n in the range, plus the lobe's
  // ridge; |bilinear D - D| over the same (a, b). Max over samples.
  double max_abs_error = 0, diffuse_max_abs_error = 0;
  // Largest step between neighbouring texels of any level (what GL_LINEAR's weights may add).
  double max_texel_step = 0;
  size_t samples = 0;
  uint64_t seed = 0;
  double log_step() const { return levels > 1 ? (logn1 - logn0) / (levels - 1) : 0.0; }
};

// Levels at most `max_log_step` apart in log n (at least 2, at most `max_levels`) over
// [n_min, n_max], each on `size` texels of `index`. Throws on a range that is not finite and
// positive.
SpecularStack bake_specular_stack(double n_min, double n_max, int size, BakeIndex index,
                                  double max_log_step = 0.05, int max_levels = 64,
                                  uint64_t seed = 1);

// The stack a line material with maps draws with: over its map of n's range (throws, naming the
// map, where it holds no positive value), or at its one n without a map of n; levels as
// bake_specular_stack's.
SpecularStack bake_material_stack(const Material& m, int size, BakeIndex index,
                                  double max_log_step = 0.05, int max_levels = 64);

// bake.json's "specular_stack" section, with specular_stack.exr written into `dir`; and the stack
// read back from such a section of `file` (errors name the file and key) beside tables `t`.
nlohmann::json write_specular_stack(const std::string& dir, const SpecularStack& st);
SpecularStack read_specular_stack(const nlohmann::json& section, const std::string& file,
                                  const BakeTables& t);

// The levels one after the other (level, then row, then column): a 2D array texture's texels.
std::vector<float> stack_levels(const SpecularStack& st);

// What the shader computes, on the CPU: S at (a, b) and n from the stack.
double stack_lookup(const SpecularStack& st, double a, double b, double n);

// The fiber model at many n (ours, for a fiber material with a map of n): F's tables (the only
// factor that depends on n) at levels spaced evenly in log n over the map's range, beside the
// line model's SpecularStack for S_line. The shader takes S_line and F from the two levels either
// side of its fragment's log n (each stack its own levels) and blends them with the exact weight.
// The error of the whole lookup against the full fiber model is measured at bake time over random
// L, V, s and n in the range.
struct FiberStack {
  int levels = 0;
  double logn0 = 0, logn1 = 0;
  std::vector<float> F;     // level k's F (FiberBakeTables::F's layout) from k * level_floats on
  size_t level_floats = 0;  // nphi * nphi * ns * nk
  double max_abs_error = 0, rms_error = 0, peak_value = 0;
  size_t samples = 0;
  uint64_t seed = 0;
  double seconds = 0;
  double log_step() const { return levels > 1 ? (logn1 - logn0) / (levels - 1) : 0.0; }
  const float* level(int k) const { return F.data() + static_cast<size_t>(k) * level_floats; }
};

// Levels at most `max_log_step` apart in log n (at least 2, at most `max_levels`) over the range
// of `st` (the material's map of n), on fb's grid; the error measured at m's k_d, k_s with
// `line`'s D and `st`. F is smooth in log n: at steps of 0.2 a lookup between levels differs from
// tables baked at its very n by well under the tables' own error against the full model (test
// FiberPreview.AMapOfNIsDrawnPerFragment: under a quarter of it).
FiberStack bake_fiber_stack(const Material& m, const FiberBakeTables& fb, const BakeTables& line,
                            const SpecularStack& st, double max_log_step = 0.2, int max_levels = 28,
                            uint64_t seed = 1, const ProgressSink* progress = nullptr);

// What the fiber pass computes with a map of n, on the CPU: k_d D + k_s S at the fragment's n
// (m's k_d, k_s; its n ignored), L and V in the fiber frame, topology s.
void fiber_stack_eval(const Material& m, const BakeTables& line, const SpecularStack& st,
                      const FiberBakeTables& fb, const FiberStack& fs, const LocalDir& L,
                      const LocalDir& V, double s, double n, double out[3]);

// The F stack as 2D array layers for GL: layer k * ns + is holds level k's F at topology is, its
// nk tables of phi side by side (width nk * nphi: texel (ik * nphi + i, j)). So the layers,
// levels * ns (at most 28 * 9 = 252), stay within the 256 that WebGL 2 guarantees, and a lookup
// at a tile's texel centres keeps bilinear filtering inside the tile.
std::vector<float> fiber_stack_layers(const FiberBakeTables& fb, const FiberStack& fs);

// Writes diffuse/specular/combined as float EXR, 8- and 16-bit PNG, and bake.json (the sidecar:
// indexing, decoding scales, texture matrix, measured error, the command that generated it).
// With a fiber material, also fiber_G.exr and fiber_F.exr (layers stacked vertically).
// With a line material's map of n, also specular_stack.exr (the stack's levels stacked
// vertically); the material's maps travel with the bake (maps/).
void write_bake(const std::string& dir, const Material& m, const BakeTables& t,
                const std::string& command, const FiberBakeTables* fiber = nullptr,
                const SpecularStack* stack = nullptr);

// What write_bake wrote, read back: the material (its maps relative to the bake folder), the
// tables with their indexing and measured error, and the fiber tables when there are any.
// Anything missing or malformed is an error naming the file and key.
struct BakeFolder {
  Material material;  // its maps loaded
  BakeTables tables;
  bool has_fiber = false;
  FiberBakeTables fiber;
  bool has_stack = false;
  SpecularStack stack;
};
BakeFolder read_bake(const std::string& dir);

}  // namespace aniso
