#include "render/bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "core/error.h"
#include "io/files.h"
#include "io/image_io.h"
#include "io/json_util.h"
#include "io/material_io.h"
#include "models/line_model.h"

namespace aniso {

const char* index_name(BakeIndex i) { return i == BakeIndex::kAngle ? "angle" : "cosine"; }

BakeIndex parse_index(const std::string& name) {
  if (name == "angle") return BakeIndex::kAngle;
  if (name == "cosine") return BakeIndex::kCosine;
  throw Error("bake: --index must be angle or cosine (got '" + name + "')");
}

double texel_cosine(int i, int n, BakeIndex index) {
  if (i == n - 1) return 1.0;  // exact ends: grazing is a texel centre
  if (i == 0) return -1.0;
  return index == BakeIndex::kAngle ? -std::cos(M_PI * i / (n - 1)) : -1.0 + 2.0 * i / (n - 1);
}

double texel_coord(double a, int n, BakeIndex index) {
  a = std::clamp(a, -1.0, 1.0);
  return index == BakeIndex::kAngle ? std::acos(-a) / M_PI * (n - 1) : (a + 1.0) * 0.5 * (n - 1);
}

double lookup_bilinear(const Image& t, double a, double b, int ch, BakeIndex index) {
  const int n = t.width;
  const double fa = texel_coord(a, n, index), fb = texel_coord(b, n, index);
  const int ia = std::min(static_cast<int>(fa), n - 2), ib = std::min(static_cast<int>(fb), n - 2);
  const double wa = fa - ia, wb = fb - ib;
  // Row = b (t coordinate), column = a (s coordinate).
  return (1 - wa) * (1 - wb) * t.at(ia, ib, ch) + wa * (1 - wb) * t.at(ia + 1, ib, ch) +
         (1 - wa) * wb * t.at(ia, ib + 1, ch) + wa * wb * t.at(ia + 1, ib + 1, ch);
}

BakeTables bake_line(const Material& m, int n, BakeIndex index, uint64_t seed) {
  if (n < 2 || n > 8192) throw Error("bake: --size must be between 2 and 8192 (got " + std::to_string(n) + ")");
  const auto t0 = std::chrono::steady_clock::now();
  BakeTables t;
  t.size = n;
  t.index = index;
  t.seed = seed;
  t.diffuse = Image(n, n, 1);
  t.specular = Image(n, n, 1);
  t.combined = Image(n, n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double D, S;
      line_DS(texel_cosine(i, n, index), texel_cosine(j, n, index), m.n, &D, &S);
      t.diffuse.at(i, j, 0) = static_cast<float>(D);
      t.specular.at(i, j, 0) = static_cast<float>(S);
      for (int c = 0; c < 3; ++c) t.combined.at(i, j, c) = static_cast<float>(m.kd[c] * D + m.ks[c] * S);
    }
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Error against direct evaluation: random pairs plus the ridge of the lobe (b = -a, where
  // s_L s_V - a b = 1), where bilinear interpolation of a sharp lobe errs most.
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double sum2 = 0;
  auto check = [&](double a, double b) {
    double D, S;
    line_DS(a, b, m.n, &D, &S);
    for (int c = 0; c < 3; ++c) {
      const double ref = m.kd[c] * D + m.ks[c] * S;
      const double err = std::abs(lookup_bilinear(t.combined, a, b, c, index) - ref);
      t.max_abs_error = std::max(t.max_abs_error, err);
      t.peak_value = std::max(t.peak_value, ref);
      sum2 += err * err;
    }
    ++t.samples;
  };
  constexpr int kRandomSamples = 100000, kRidgeSamples = 20000;
  for (int k = 0; k < kRandomSamples; ++k) check(u(rng), u(rng));
  for (int k = 0; k < kRidgeSamples; ++k) {
    const double a = u(rng);
    check(a, std::clamp(-a + 0.02 * u(rng), -1.0, 1.0));
  }
  t.rms_error = std::sqrt(sum2 / (3.0 * t.samples));
  return t;
}

void write_bake(const std::string& dir, const Material& m, const BakeTables& t, const std::string& command) {
  using jsonu::json;
  write_folder_atomically(dir, [&](const std::string& tmp) {
    json files = json::object();
    auto emit = [&](const std::string& stem, const Image& img) {
      double maxv = 0;
      for (float v : img.px) maxv = std::max(maxv, static_cast<double>(v));
      const double scale = maxv > 0 ? maxv : 1.0;
      Image norm = img;
      for (float& v : norm.px) v = static_cast<float>(v / scale);
      write_exr(join_path(tmp, stem + ".exr"), img);
      write_png(join_path(tmp, stem + "_8.png"), norm, 8);
      write_png(join_path(tmp, stem + "_16.png"), norm, 16);
      // Quantisation error of the PNGs, in model units (half a step of each depth).
      files[stem] = {{"exr", stem + ".exr"},
                     {"png8", stem + "_8.png"},
                     {"png16", stem + "_16.png"},
                     {"channels", img.channels},
                     {"png_decode", "value = png / (2^bits - 1) * scale"},
                     {"scale", scale},
                     {"png8_quantisation_max_error", 0.5 * scale / 255.0},
                     {"png16_quantisation_max_error", 0.5 * scale / 65535.0}};
    };
    emit("diffuse", t.diffuse);
    emit("specular", t.specular);
    emit("combined", t.combined);
    json material;
    material_to_json(m, &material);
    const int n = t.size;
    const double sc = (n - 1.0) / n, off = 0.5 / n;
    json j = {
        {"format", "aniso-bake"},
        {"version", 1},
        {"model", "line"},
        {"size", n},
        {"generated_with", command},
        {"index",
         {{"kind", index_name(t.index)},
          {"s", t.index == BakeIndex::kAngle ? "a = <L,T>: column; texel i centred on acos(-a) = pi i / (size - 1)"
                                             : "a = <L,T>: column; texel i centred on a = -1 + 2 i / (size - 1)"},
          {"t", "b = <V,T>: row (row 0 first in the file), indexed like a"},
          {"lookup", t.index == BakeIndex::kAngle
                         ? "s = (a + 1) / 2 from the paper's matrix (k = 1, o = 0); u = (acos(1 - 2 s) / pi * (size - 1) + "
                           "0.5) / size, likewise v from t; bilinear"
                         : "u = ((a + 1) / 2 * (size - 1) + 0.5) / size, likewise v from b; bilinear"},
          {"texture_matrix",
           "M = diag(k, k, 1, 1) * 1/2 [[Lx Ly Lz 1], [Vx Vy Vz 1], [0 0 0 0], [0 0 0 2]] + offset column "
           "(o, o, 0, 0), k = (size - 1) / size, o = 0.5 / size; applied to (T, 1)"},
          {"k", t.index == BakeIndex::kAngle ? 1.0 : sc},
          {"o", t.index == BakeIndex::kAngle ? 0.0 : off}}},
        {"contents",
         {{"diffuse", "D(a) = sqrt(1 - a^2) (grey)"},
          {"specular", "S(a, b) = ((sqrt(1-a^2) sqrt(1-b^2) - a b)^+)^n (grey)"},
          {"combined", "k_d D + k_s S (RGB)"},
          {"not_baked", "<N,L>^+ (per fragment), the isotropic term (its own pass), the second fiber (a second "
                        "lookup with T2, weights w and 1 - w)"}}},
        {"files", files},
        {"error",
         {{"against", "direct evaluation of k_d D + k_s S, float table, bilinear lookup"},
          {"max_abs", t.max_abs_error},
          {"rms", t.rms_error},
          {"peak_value", t.peak_value},
          {"max_rel_to_peak", t.peak_value > 0 ? t.max_abs_error / t.peak_value : 0.0},
          {"samples", t.samples},
          {"seed", t.seed}}},
        {"bake_seconds", t.seconds},
        {"material", material}};
    write_json_file(join_path(tmp, "bake.json"), j);
  });
}

}  // namespace aniso
