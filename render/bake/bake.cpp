#include "render/bake/bake.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/progress.h"
#include "core/random_dir.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "models/evaluate.h"
#include "models/fiber_model.h"
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

double max_texel_step(const Image& t) {
  double step = 0;
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x)
      for (int c = 0; c < t.channels; ++c) {
        const float v = t.at(x, y, c);
        if (x + 1 < t.width) step = std::max(step, double(std::abs(t.at(x + 1, y, c) - v)));
        if (y + 1 < t.height) step = std::max(step, double(std::abs(t.at(x, y + 1, c) - v)));
      }
  return step;
}

BakeTables bake_line(const Material& m, int n, BakeIndex index, uint64_t seed) {
  if (n < 2 || n > 8192)
    throw Error("bake: --size must be between 2 and 8192 (got " + std::to_string(n) + ")");
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
      for (int c = 0; c < 3; ++c)
        t.combined.at(i, j, c) = static_cast<float>(m.kd[c] * D + m.ks[c] * S);
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

namespace {

// The in-plane directions of texel (i, j) of the factor tables: phi_l, phi_v from -90 to 90 deg
// with texel centres on the ends, kept strictly above the surface there.
void fiber_table_angles(int i, int j, int nphi, double* lb, double* ln, double* vb, double* vn) {
  constexpr double kGrazingCos = 1e-9;
  const double pl = -M_PI / 2 + M_PI * i / (nphi - 1), pv = -M_PI / 2 + M_PI * j / (nphi - 1);
  *lb = std::sin(pl), *ln = std::max(std::cos(pl), kGrazingCos);
  *vb = std::sin(pv), *vn = std::max(std::cos(pv), kGrazingCos);
}

// F at one texel's angles, topology s and exponent n for k = 0 .. nk - 1, written `stride` floats
// apart.
void fiber_F_entries(double lb, double ln, double vb, double vn, double n, double s, int nk,
                     size_t stride, float* out) {
  for (int k = 0; k < nk; ++k) {
    const double kk = static_cast<double>(k) / (nk - 1);
    double D, F = 0;  // k = 1 (kappa infinite): the lobe has no width, F = 0
    if (kk < 1.0) {
      // s_L = s_V = 1 (unit in-plane vectors) and ab chosen so that kappa = 2 / (1 - ab); at
      // kappa = 0 a huge -ab makes (1 - kappa sin^2 x)^n = 1: the lit-and-visible fraction.
      const double kappa = kk / (1 - kk);
      constexpr double kHugeAB = 1e12;
      const double ab = kappa > 0 ? 1 - 2 / kappa : -kHugeAB;
      fiber_DS(lb, ln, vb, vn, 1.0, ab, n, s, FiberAccuracy{}, &D, &F,
               static_cast<double*>(nullptr), true);
    }
    out[k * stride] = static_cast<float>(F);
  }
}

// Continuous texel coordinate of an angle in [-pi/2, pi/2] on n texels with centres on the ends.
double angle_texel(double phi, int n) {
  return std::clamp((phi + M_PI / 2) / M_PI, 0.0, 1.0) * (n - 1);
}

struct Lerp {
  int i0;
  double w;  // weight of i0 + 1
};
Lerp lerp_of(double f, int n) {
  const int i = std::clamp(static_cast<int>(f), 0, n - 2);
  return {i, std::clamp(f - i, 0.0, 1.0)};
}

}  // namespace

// Factors G and F at the in-plane angles, topology s and kappa (multi-linear in the tables).
void fiber_factors(const FiberBakeTables& fb, const float* Ftab, double phi_l, double phi_v,
                   double s, double kappa, double* G, double* F) {
  const Lerp li = lerp_of(angle_texel(phi_l, fb.nphi), fb.nphi),
             lj = lerp_of(angle_texel(phi_v, fb.nphi), fb.nphi);
  const Lerp ls = lerp_of(std::clamp(s, 0.0, 1.0) * (fb.ns - 1), fb.ns);
  const double kk = std::isfinite(kappa) ? kappa / (1 + kappa) : 1.0;
  const Lerp lk = lerp_of(kk * (fb.nk - 1), fb.nk);
  *G = 0;
  *F = 0;
  const size_t np = fb.nphi;
  for (int c = 0; c < 2; ++c)
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        const double w = (a ? li.w : 1 - li.w) * (b ? lj.w : 1 - lj.w) * (c ? ls.w : 1 - ls.w);
        const size_t base = (static_cast<size_t>(ls.i0 + c) * np + (lj.i0 + b)) * np + (li.i0 + a);
        *G += w * fb.G[base];
        for (int d = 0; d < 2; ++d) {
          const size_t fi =
              ((static_cast<size_t>(ls.i0 + c) * fb.nk + (lk.i0 + d)) * np + (lj.i0 + b)) * np +
              (li.i0 + a);
          *F += w * (d ? lk.w : 1 - lk.w) * Ftab[fi];
        }
      }
}

void bake_fiber_F(double n, int nphi, int ns, int nk, float* F) {
  tbb::parallel_for(0, ns, [&](int is) {
    const double s = static_cast<double>(is) / (ns - 1);
    for (int j = 0; j < nphi; ++j)
      for (int i = 0; i < nphi; ++i) {
        double lb, ln, vb, vn;
        fiber_table_angles(i, j, nphi, &lb, &ln, &vb, &vn);
        fiber_F_entries(lb, ln, vb, vn, n, s, nk, static_cast<size_t>(nphi) * nphi,
                        &F[((static_cast<size_t>(is) * nk) * nphi + j) * nphi + i]);
      }
  });
}

FiberBakeTables bake_fiber(const Material& m, const BakeTables& line, int nphi, int ns, int nk,
                           uint64_t seed, const ProgressSink* progress) {
  if (nphi < 2 || ns < 2 || nk < 2) throw Error("bake: fiber table sizes must be at least 2");
  const auto t0 = std::chrono::steady_clock::now();
  FiberBakeTables fb;
  fb.nphi = nphi;
  fb.ns = ns;
  fb.nk = nk;
  fb.G.assign(static_cast<size_t>(nphi) * nphi * ns, 0.f);
  fb.F.assign(static_cast<size_t>(nphi) * nphi * ns * nk, 0.f);
  Progress bar("bake: fiber factor tables", static_cast<size_t>(ns) * nphi, progress);
  tbb::parallel_for(0, ns, [&](int is) {
    const double s = static_cast<double>(is) / (ns - 1);
    for (int j = 0; j < nphi; ++j, bar.advance())
      for (int i = 0; i < nphi; ++i) {
        double lb, ln, vb, vn;
        fiber_table_angles(i, j, nphi, &lb, &ln, &vb, &vn);
        double D, S;
        fiber_DS(lb, ln, vb, vn, 0.0, 0.0, m.n, s, FiberAccuracy{}, &D, &S);
        fb.G[(static_cast<size_t>(is) * nphi + j) * nphi + i] = static_cast<float>(D);
        fiber_F_entries(lb, ln, vb, vn, m.n, s, nk, nphi * nphi,
                        &fb.F[((static_cast<size_t>(is) * nk) * nphi + j) * nphi + i]);
      }
  });
  fb.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Error against the full model over random directions and topology values (seeded).
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> errs;
  double sum2 = 0;
  const Material line_only = [&] {
    Material x = m;
    x.model = Model::kLine;
    return x;
  }();
  constexpr int kSamples = 20000;
  for (int it = 0; it < kSamples; ++it) {
    const LocalDir L = random_upper_dir(rng, g), V = random_upper_dir(rng, g);
    const double s = u(rng);
    double ref[3], baked[3];
    fiber_reflectance(fiber_frame_params(m), s, L, V, FiberAccuracy{}, ref);
    fiber_baked_eval(line_only, line, fb, L, V, s, baked);
    for (int c = 0; c < 3; ++c) {
      const double e = std::abs(baked[c] - ref[c]);
      errs.push_back(e);
      sum2 += e * e;
      fb.max_abs_error = std::max(fb.max_abs_error, e);
      fb.peak_value = std::max(fb.peak_value, ref[c]);
    }
    ++fb.samples;
  }
  fb.rms_error = std::sqrt(sum2 / errs.size());
  std::nth_element(errs.begin(), errs.begin() + errs.size() * 99 / 100, errs.end());
  fb.p99_error = errs[errs.size() * 99 / 100];
  return fb;
}

bool fiber_coords(const LocalDir& L, const LocalDir& V, FiberCoords* c) {
  if (!(L.n > 0) || !(V.n > 0)) return false;
  c->a = L.u, c->b = V.u;
  const double sL = std::hypot(L.w, L.n), sV = std::hypot(V.w, V.n);
  c->phi_l = std::atan2(L.w, L.n), c->phi_v = std::atan2(V.w, V.n);
  const double g0 = sL * sV - c->a * c->b;
  c->kappa = g0 > 0 ? 2 * sL * sV / g0 : std::numeric_limits<double>::infinity();
  return true;
}

void fiber_baked_eval(const Material& m, const BakeTables& line, const FiberBakeTables& fb,
                      const LocalDir& L, const LocalDir& V, double s, double out[3]) {
  out[0] = out[1] = out[2] = 0;
  FiberCoords fc;
  if (!fiber_coords(L, V, &fc)) return;
  double G, F;
  fiber_factors(fb, fb.F.data(), fc.phi_l, fc.phi_v, s, fc.kappa, &G, &F);
  const double Dl = lookup_bilinear(line.diffuse, fc.a, fc.b, 0, line.index);
  const double Sl = lookup_bilinear(line.specular, fc.a, fc.b, 0, line.index);
  for (int c = 0; c < 3; ++c) out[c] = m.kd[c] * Dl * G + m.ks[c] * Sl * F;
}

void write_bake(const std::string& dir, const Material& m, const BakeTables& t,
                const std::string& command, const FiberBakeTables* fiber,
                const SpecularStack* stack) {
  using jsonu::json;
  write_folder_atomically(dir, OutputKind::kBake, [&](const std::string& tmp) {
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
    json fiber_json = nullptr;
    if (fiber) {
      Image G(fiber->nphi, fiber->nphi * fiber->ns, 1),
          F(fiber->nphi, fiber->nphi * fiber->ns * fiber->nk, 1);
      G.px = fiber->G;
      F.px = fiber->F;
      write_exr(join_path(tmp, "fiber_G.exr"), G);
      write_exr(join_path(tmp, "fiber_F.exr"), F);
      fiber_json = {
          {"G", "fiber_G.exr: width nphi (phi_l), rows nphi * ns: row = is * nphi + j (phi_v)"},
          {"F",
           "fiber_F.exr: width nphi (phi_l), rows nphi * ns * nk: row = (is * nk + k) * nphi + j"},
          {"nphi", fiber->nphi},
          {"ns", fiber->ns},
          {"nk", fiber->nk},
          {"angles",
           "phi = atan2(<L,B>, <L,N>) (likewise V), texel i at -90 + 180 i / (nphi - 1) deg"},
          {"s", "texel is at s = is / (ns - 1)"},
          {"k",
           "k = kappa / (1 + kappa), kappa = 2 s_L s_V / (s_L s_V - a b); texel k at k / (nk - 1)"},
          {"evaluate",
           "k_d * diffuse(a, b) * G(phi_l, phi_v, s) + k_s * specular(a, b) * F(phi_l, phi_v, s, "
           "k); no <N,L> "
           "factor; multilinear lookups"},
          {"error",
           {{"against", "the full fiber model (models/fiber_model.h), random L, V, s"},
            {"max_abs", fiber->max_abs_error},
            {"rms", fiber->rms_error},
            {"p99", fiber->p99_error},
            {"peak_value", fiber->peak_value},
            {"samples", fiber->samples}}},
          {"bake_seconds", fiber->seconds}};
    }
    // The maps the material names travel with the bake (an engine needs them as much as the
    // tables); the material recorded below names them relative to bake.json.
    Material mm = m;
    json maps = json::object();
    auto carry = [&](bool has, std::string* rel, const char* key, const char* meaning) {
      if (!has) return;
      const std::string src = join_path(m.base_dir, *rel);
      std::string dst = "maps/" + std::filesystem::path(src).filename().string();
      // Two maps of one name from different folders: the second under its key's name too.
      if (std::filesystem::exists(join_path(tmp, dst)))
        dst = "maps/" + std::string(key) + "_" + std::filesystem::path(src).filename().string();
      write_text_file(join_path(tmp, dst), read_text_file(src));
      *rel = dst;
      maps[key] = {{"file", dst}, {"meaning", meaning}};
    };
    auto* mm_map = mm.topology_as<TopologyMapRef>();
    auto* mm_s_map = mm.topology_as<SMapRef>();
    carry(
        m.fiber() && mm_map, mm_map ? &mm_map->file : nullptr, "topology.map",
        "topology map h in [0, 1] (first channel; integer images divided by their maximum), "
        "m = 2h - 1, over glTF uv with wrap; s from s_math and the amplitude (docs/models.md §4)");
    carry(m.fiber() && mm_s_map, mm_s_map ? &mm_s_map->file : nullptr, "topology.s_map",
          "the topology s itself per texel (channel R; G = its sigma, -1 where undetermined), "
          "over glTF uv, bilinear with wrap");
    MaterialMaps& mp = mm.maps;
    carry(!mp.kd_file.empty(), &mp.kd_file, "kd", "k_d per texel (RGB), over uv (docs/formats.md)");
    carry(!mp.ks_file.empty(), &mp.ks_file, "ks", "k_s per texel (RGB), over uv");
    carry(!mp.n_file.empty(), &mp.n_file, "n",
          "n per texel (R): the specular stack's level from log n (specular_stack)");
    carry(!mp.fiber_file.empty(), &mp.fiber_file, "fiber",
          "(cos 2 psi, sin 2 psi) per texel (R, G): T turned by psi about N from the reference "
          "tangent");
    carry(!mp.amplitude_file.empty(), &mp.amplitude_file, "amplitude",
          "the topology map's amplitude A per texel (R)");
    json material;
    material_to_json(mm, &material);
    const int n = t.size;
    const double sc = (n - 1.0) / n, off = 0.5 / n;
    json j = {
        {"format", "aniso-bake"},
        {"version", 1},
        {"model", model_name(m.model)},
        {"size", n},
        {"generated_with", command},
        {"index",
         {{"kind", index_name(t.index)},
          {"s", t.index == BakeIndex::kAngle
                    ? "a = <L,T>: column; texel i centred on acos(-a) = pi i / (size - 1)"
                    : "a = <L,T>: column; texel i centred on a = -1 + 2 i / (size - 1)"},
          {"t", "b = <V,T>: row (row 0 first in the file), indexed like a"},
          {"lookup",
           t.index == BakeIndex::kAngle
               ? "s = (a + 1) / 2 from the paper's matrix (k = 1, o = 0); u = (acos(1 - 2 s) / pi "
                 "* (size - 1) + "
                 "0.5) / size, likewise v from t; bilinear"
               : "u = ((a + 1) / 2 * (size - 1) + 0.5) / size, likewise v from b; bilinear"},
          {"texture_matrix",
           "M = diag(k, k, 1, 1) * 1/2 [[Lx Ly Lz 1], [Vx Vy Vz 1], [0 0 0 0], [0 0 0 2]] + offset "
           "column "
           "(o, o, 0, 0), k = (size - 1) / size, o = 0.5 / size; applied to (T, 1)"},
          {"k", t.index == BakeIndex::kAngle ? 1.0 : sc},
          {"o", t.index == BakeIndex::kAngle ? 0.0 : off}}},
        {"contents",
         {{"diffuse", "D(a) = sqrt(1 - a^2) (grey)"},
          {"specular", "S(a, b) = ((sqrt(1-a^2) sqrt(1-b^2) - a b)^+)^n (grey)"},
          {"combined", "k_d D + k_s S (RGB)"},
          {"not_baked",
           "<N,L>^+ (per fragment), the isotropic term (its own pass), the second fiber (a second "
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
    if (fiber) j["fiber"] = fiber_json;
    if (!maps.empty()) j["maps"] = maps;
    if (stack) j["specular_stack"] = write_specular_stack(tmp, *stack);
    write_json_file(join_path(tmp, "bake.json"), j);
  });
}

BakeFolder read_bake(const std::string& dir) {
  using jsonu::Ctx;
  using jsonu::json;
  const std::string file = join_path(dir, "bake.json");
  const json j = jsonu::parse_file(read_text_file(file), file);
  const Ctx root{file, ""};
  if (jsonu::str(jsonu::need(j, "format", root), root.at("format")) != "aniso-bake")
    root.at("format").fail("expected \"aniso-bake\"");
  if (jsonu::num(jsonu::need(j, "version", root), root.at("version")) != 1)
    root.at("version").fail("unsupported version (this reader knows 1)");
  BakeFolder b;
  b.material = material_from_json(jsonu::need(j, "material", root), file + ": material");
  b.material.base_dir = dir;
  BakeTables& t = b.tables;
  const double size = jsonu::num(jsonu::need(j, "size", root), root.at("size"));
  if (size < 2 || size > 8192 || size != std::floor(size))
    root.at("size").fail("must be in [2, 8192]");
  t.size = static_cast<int>(size);
  const json& idx = jsonu::need(j, "index", root);
  t.index =
      parse_index(jsonu::str(jsonu::need(idx, "kind", root.at("index")), root.at("index.kind")));
  const json& err = jsonu::need(j, "error", root);
  const Ctx ce = root.at("error");
  t.max_abs_error = jsonu::num(jsonu::need(err, "max_abs", ce), ce.at("max_abs"));
  t.rms_error = jsonu::num(jsonu::need(err, "rms", ce), ce.at("rms"));
  t.peak_value = jsonu::num(jsonu::need(err, "peak_value", ce), ce.at("peak_value"));
  t.samples = static_cast<size_t>(jsonu::num_or(err, "samples", 0, ce));
  t.seed = static_cast<uint64_t>(jsonu::num_or(err, "seed", 1, ce));
  const json& files = jsonu::need(j, "files", root);
  auto table = [&](const char* stem, int channels) {
    const Ctx c = root.at("files").at(stem);
    const std::string name =
        jsonu::str(jsonu::need(jsonu::need(files, stem, root.at("files")), "exr", c), c.at("exr"));
    Image img = read_image(join_path(dir, name), t.size, t.size).image;
    if (img.channels != channels)
      c.fail(name + " has " + std::to_string(img.channels) + " channels, expected " +
             std::to_string(channels));
    return img;
  };
  t.diffuse = table("diffuse", 1);
  t.specular = table("specular", 1);
  t.combined = table("combined", 3);
  if (j.contains("fiber") && !j["fiber"].is_null()) {
    const json& f = j["fiber"];
    const Ctx c = root.at("fiber");
    FiberBakeTables& fb = b.fiber;
    auto count = [&](const char* key) {
      const double v = jsonu::num(jsonu::need(f, key, c), c.at(key));
      if (v < 2 || v > 4096 || v != std::floor(v))
        c.at(key).fail("must be an integer in [2, 4096]");
      return static_cast<int>(v);
    };
    fb.nphi = count("nphi");
    fb.ns = count("ns");
    fb.nk = count("nk");
    const json& fe = jsonu::need(f, "error", c);
    fb.max_abs_error = jsonu::num(jsonu::need(fe, "max_abs", c.at("error")), c.at("error.max_abs"));
    fb.rms_error = jsonu::num_or(fe, "rms", 0, c.at("error"));
    fb.p99_error = jsonu::num_or(fe, "p99", 0, c.at("error"));
    fb.peak_value = jsonu::num_or(fe, "peak_value", 0, c.at("error"));
    const Image G = read_image(join_path(dir, "fiber_G.exr"), fb.nphi, fb.nphi * fb.ns).image;
    const Image F =
        read_image(join_path(dir, "fiber_F.exr"), fb.nphi, fb.nphi * fb.ns * fb.nk).image;
    if (G.channels != 1 || F.channels != 1) c.fail("fiber_G.exr and fiber_F.exr hold one channel");
    fb.G = G.px;
    fb.F = F.px;
    b.has_fiber = true;
  }
  load_material_maps(file, &b.material);
  if (j.contains("specular_stack")) {
    b.stack = read_specular_stack(j["specular_stack"], file, t);
    b.has_stack = true;
  }
  if (b.material.fiber() && !b.has_fiber)
    root.fail("a fiber material's bake needs its \"fiber\" tables");
  return b;
}

}  // namespace aniso
