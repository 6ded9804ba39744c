#include "photo/import/synth_shoot.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <random>

#include "core/angles.h"
#include "core/color.h"
#include "core/error.h"
#include "core/frame.h"
#include "core/gauss.h"
#include "core/lens.h"
#include "core/progress.h"
#include "geometry/raycast.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "models/evaluate.h"
#include "models/shade.h"
#include "photo/shoot/raw.h"
#include "photo/shoot/shoot.h"

namespace aniso {

namespace {

constexpr double kInkAlbedo = 0.04, kTableAlbedo = 0.3;
constexpr double kPaperMarginM = 0.01;  // white paper around the printed board
constexpr double kTexelM = 0.000125;    // board texture resolution (0.125 mm)

// The table (z = 0, a metre beyond the board on every side) and the sample plate on top of it
// (z = -height, a triangle fan of its convex outline). Normals face the camera side (-z).
TriMesh shoot_scene(const PhotoShootOptions& o) {
  TriMesh m;
  const double W = o.board.squares_x * o.board.square_m, H = o.board.squares_y * o.board.square_m;
  const Vec3 N{0, 0, -1}, Ub{1, 0, 0}, Us{o.tangent[0], o.tangent[1], 0};
  auto vertex = [&](double x, double y, double z, const Vec3& U) {
    m.P.push_back({x, y, z});
    m.N.push_back(N);
    m.U.push_back(U);
    m.uv.push_back({static_cast<float>(x / W), static_cast<float>(y / H)});
    return static_cast<uint32_t>(m.P.size() - 1);
  };
  const uint32_t a = vertex(-1, -1, 0, Ub), b = vertex(W + 1, -1, 0, Ub),
                 c = vertex(W + 1, H + 1, 0, Ub), d = vertex(-1, H + 1, 0, Ub);
  m.tri.push_back({a, b, c});
  m.tri.push_back({a, c, d});
  const uint32_t first = static_cast<uint32_t>(m.P.size());
  for (const auto& p : o.polygon) vertex(p[0], p[1], -o.height_m, Us);
  for (uint32_t i = 1; i + 1 < o.polygon.size(); ++i)
    m.tri.push_back({first, first + i, first + i + 1});
  m.can_self_shadow = true;  // the plate shadows the board
  return m;
}

// The board as printed on paper, box-filtered through a summed-area table: the mean albedo over
// any axis-aligned rectangle of the board plane.
class BoardAlbedo {
 public:
  BoardAlbedo(const BoardSpec& b, double paper) : paper_(paper) {
    const Image board = render_board(b, 0.0254 / kTexelM);
    margin_ = static_cast<int>(std::lround(kPaperMarginM / kTexelM));
    w_ = board.width + 2 * margin_;
    h_ = board.height + 2 * margin_;
    texel_ = b.squares_x * b.square_m / board.width;
    sat_.assign(static_cast<size_t>(w_ + 1) * (h_ + 1), 0.0);
    for (int y = 0; y < h_; ++y) {
      double row = 0;
      for (int x = 0; x < w_; ++x) {
        const int bx = x - margin_, by = y - margin_;
        const bool on_board = bx >= 0 && by >= 0 && bx < board.width && by < board.height;
        row += on_board ? kInkAlbedo + (paper - kInkAlbedo) * board.at(bx, by, 0) : paper;
        sat_[idx(x + 1, y + 1)] = sat_[idx(x + 1, y)] + row;
      }
    }
  }
  // Mean albedo over [x0, x1] x [y0, y1] (board metres); the table beyond the paper.
  double mean(double x0, double x1, double y0, double y1) const {
    const double u0 = x0 / texel_ + margin_, u1 = x1 / texel_ + margin_;
    const double v0 = y0 / texel_ + margin_, v1 = y1 / texel_ + margin_;
    if (u1 <= 0 || v1 <= 0 || u0 >= w_ || v0 >= h_) return kTableAlbedo;
    if (u0 < 0 || v0 < 0 || u1 > w_ || v1 > h_) return 0.5 * (kTableAlbedo + paper_);
    const double area = std::max((u1 - u0) * (v1 - v0), 1e-9);
    return (S(u1, v1) - S(u0, v1) - S(u1, v0) + S(u0, v0)) / area;
  }

 private:
  size_t idx(int x, int y) const { return static_cast<size_t>(y) * (w_ + 1) + x; }
  // The integral over [0, u] x [0, v], bilinear between the table's integer points.
  double S(double u, double v) const {
    const int x = std::clamp(static_cast<int>(u), 0, w_ - 1),
              y = std::clamp(static_cast<int>(v), 0, h_ - 1);
    const double tx = u - x, ty = v - y;
    return (1 - tx) * (1 - ty) * sat_[idx(x, y)] + tx * (1 - ty) * sat_[idx(x + 1, y)] +
           (1 - tx) * ty * sat_[idx(x, y + 1)] + tx * ty * sat_[idx(x + 1, y + 1)];
  }
  std::vector<double> sat_;
  double paper_;
  int w_ = 0, h_ = 0, margin_ = 0;
  double texel_ = 1;
};

struct PhotoSetup {
  Mat4 world_from_camera;
  // Every lamp of the photo: the key lamp opposite the camera and, with fill_lamp, a fill.
  std::vector<Light> lamps;
};

// Camera i of n: 12-42 degrees from the board's normal at golden-angle azimuths, 0.45-0.6 m from
// the sample's centre, rolled by up to 15 degrees; the lamp near the mirror direction of the
// camera (so the highlight crosses the sample), 0.5-0.8 m away, irradiance about 1 at the centre.
PhotoSetup photo_setup(const PhotoShootOptions& o, int i, const Vec3& centre,
                       std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const double f = (i + 0.5) / o.photos;
  const bool upright = o.walk == "upright";
  // Upright: 40-70 degrees above the board (20-50 from its normal), evenly round it.
  const double polar = deg_to_rad(upright ? 20 + 30 * f : 12 + 30 * f);
  const double azimuth = upright ? 2 * M_PI * i / o.photos : i * 2.39996322972865332;
  const double dist = 0.45 + 0.15 * (0.5 + 0.5 * uni(rng));
  const Vec3 eye = centre + Vec3(std::sin(polar) * std::cos(azimuth),
                                 std::sin(polar) * std::sin(azimuth), -std::cos(polar)) *
                                dist;
  const double roll = deg_to_rad((upright ? 3 : 15) * uni(rng));
  PhotoSetup s;
  const Vec3 target = centre + Vec3(0.01 * uni(rng), 0.01 * uni(rng), 0);
  // Upright: the image's up is the world's (-z: the camera's side of the board), within the roll
  // of a hand; turned: the board's -y.
  const Vec3 up = upright ? Vec3(std::sin(roll) * std::cos(azimuth + M_PI / 2),
                                 std::sin(roll) * std::sin(azimuth + M_PI / 2), -std::cos(roll))
                          : Vec3(std::sin(roll), -std::cos(roll), 0);
  s.world_from_camera = look_at(eye, target, up);
  const double lp =
      std::clamp(polar + deg_to_rad(12 * uni(rng)), deg_to_rad(5.0), deg_to_rad(70.0));
  const double la = azimuth + M_PI + deg_to_rad(35 * uni(rng));
  const double ld = 0.5 + 0.3 * (0.5 + 0.5 * uni(rng));
  Light key;
  key.type = Light::Type::kPoint;
  key.position =
      centre + Vec3(std::sin(lp) * std::cos(la), std::sin(lp) * std::sin(la), -std::cos(lp)) * ld;
  key.intensity = {ld * ld, ld * ld, ld * ld};
  s.lamps = {key};
  if (o.fill_lamp) {  // beside the camera, higher, at 0.4 of the key's irradiance
    const double fp = deg_to_rad(35.0), fa = azimuth + deg_to_rad(70.0), fd = 0.6;
    Light fill = key;
    fill.position =
        centre + Vec3(std::sin(fp) * std::cos(fa), std::sin(fp) * std::sin(fa), -std::cos(fp)) * fd;
    fill.intensity = {0.4 * fd * fd, 0.4 * fd * fd, 0.4 * fd * fd};
    s.lamps.push_back(fill);
  }
  return s;
}

// Where the ray of pixel corner (x, y) meets the board plane z = 0 (board x, y); NaN if never.
std::array<double, 2> corner_on_board(const Intrinsics& k, const Mat4& pose, double x, double y) {
  Vec3 P;
  if (!pixel_on_plane(k, pose, x, y, 0.0, &P)) return {NAN, NAN};
  return {P.x, P.y};
}

// Linear radiance of one photo (exposure 1).
Image render_photo(const PhotoShootOptions& o, const Intrinsics& k, const RayScene& scene,
                   const BoardAlbedo& board, const Evaluator& eval, const PhotoSetup& ps,
                   PhotoShootStats* st) {
  const GBuffer g = scene.trace(k, ps.world_from_camera, "");
  st->primary_rays += g.rays;
  const int w = k.width, h = k.height;
  std::vector<std::array<double, 2>> corners(static_cast<size_t>(w + 1) * (h + 1));
  tbb::parallel_for(0, h + 1, [&](int y) {
    for (int x = 0; x <= w; ++x)
      corners[static_cast<size_t>(y) * (w + 1) + x] =
          corner_on_board(k, ps.world_from_camera, x - 0.5, y - 0.5);
  });
  const Vec3 eye = ps.world_from_camera.translation();
  const std::vector<Light>& lights = ps.lamps;
  const double s = o.truth.uniform_s();
  std::atomic<size_t> shadow_rays{0};
  Image out(w, h, 3, 0.f);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    ShadeCounters cnt;
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        if (!g.hit[static_cast<size_t>(y) * w + x]) continue;
        SurfacePoint sp;
        if (!frame_at(g.P, g.N, g.U, x, y, &sp)) continue;
        double I[3];
        if (sp.P.z < -0.5 * o.height_m && o.brdf == "ggx") {
          Vec3 L;
          RGB E;
          double dist;
          I[0] = I[1] = I[2] = 0;
          for (const Light& lamp : lights)
            if (light_at(lamp, sp.P, &L, &E, &dist)) {
              const LocalDir Ll = to_local(sp, L), Vl = to_local(sp, normalize(eye - sp.P));
              double f[3];
              ggx_reflectance(o.truth, o.ggx_alpha_b, Ll.u, Ll.w, Ll.n, Vl.u, Vl.w, Vl.n, f);
              for (int c = 0; c < 3; ++c) I[c] += E[c] * f[c];
            }
        } else if (sp.P.z < -0.5 * o.height_m) {  // the sample's top: nothing above it shadows
          shade_point(
              eval, sp, eye, lights, {0, 0, 0}, s,
              [](const SurfacePoint&, const Vec3&, double, ShadeCounters*) { return false; }, I,
              &cnt);
        } else {  // board, paper or table: Lambertian, shadowed by the plate
          double xs[4], ys[4];
          for (int c = 0; c < 4; ++c) {
            const auto& p = corners[static_cast<size_t>(y + c / 2) * (w + 1) + x + c % 2];
            xs[c] = p[0];
            ys[c] = p[1];
          }
          const double x0 = *std::min_element(xs, xs + 4), x1 = *std::max_element(xs, xs + 4),
                       y0 = *std::min_element(ys, ys + 4), y1 = *std::max_element(ys, ys + 4);
          double albedo = board.mean(x0, x1, y0, y1);
          if (o.grey_card > 0) {  // the card over the share of the footprint it covers
            const auto& c = o.card_m;
            const double area = std::max((x1 - x0) * (y1 - y0), 1e-18);
            const double f = std::max(0.0, std::min(x1, c[2]) - std::max(x0, c[0])) *
                             std::max(0.0, std::min(y1, c[3]) - std::max(y0, c[1])) / area;
            albedo = (1 - f) * albedo + f * o.grey_card;
          }
          Vec3 L;
          RGB E;
          double dist;
          I[0] = I[1] = I[2] = 0;
          for (const Light& lamp : lights)
            if (light_at(lamp, sp.P, &L, &E, &dist) && dot(L, sp.N) > 0) {
              ++cnt.shadow_rays;
              if (!scene.occluded(sp.P + sp.N * 1e-5, L, dist - 2e-5))
                for (int c = 0; c < 3; ++c) I[c] += albedo / M_PI * E[c] * dot(L, sp.N);
            }
        }
        double lens = 1;
        if (o.vignetting != 0) {
          const double du = x - k.cx, dv = y - k.cy;  // about the lens's axis
          lens += o.vignetting * (du * du + dv * dv) / (0.25 * (double(w) * w + double(h) * h));
        }
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = static_cast<float>(lens * I[c]);
      }
    shadow_rays += cnt.shadow_rays;
  });
  st->shadow_rays += shadow_rays;
  return out;
}

// One image of photo i's bracket: exposure, read noise (each row its own seeded generator, so
// the image is the same however the rows are shared out), clipping at full scale, encoding and
// quantisation.
Image expose(const PhotoShootOptions& o, const Image& radiance, double exposure, int photo,
             int shot, size_t* saturated) {
  const bool linear = o.raw16 || o.dng;
  const double q = linear ? 65535.0 : 255.0;
  Image img = radiance;
  std::atomic<size_t> clipped{0};
  tbb::parallel_for(0, img.height, [&](int y) {
    std::seed_seq seq{static_cast<uint32_t>(o.seed), static_cast<uint32_t>(o.seed >> 32),
                      static_cast<uint32_t>(photo), static_cast<uint32_t>(shot),
                      static_cast<uint32_t>(y)};
    std::mt19937_64 rng(seq);
    const ZigguratNormal gauss;
    size_t n = 0;
    float* row = &img.px[static_cast<size_t>(y) * img.width * img.channels];
    for (int i = 0; i < img.width * img.channels; ++i) {
      double v = exposure * row[i] + o.read_noise * gauss(rng);
      if (v >= 1.0) ++n;
      v = std::clamp(v, 0.0, 1.0);
      row[i] = static_cast<float>(std::round((linear ? v : srgb_encode(v)) * q) / q);
    }
    clipped += n;
  });
  *saturated += clipped;
  return img;
}

Intrinsics shoot_camera(const PhotoShootOptions& o) {
  Intrinsics k;
  k.width = o.width;
  k.height = o.height;
  const double scale = o.width / 960.0;
  k.fx = k.fy = 1000 * scale;
  k.cx = 0.5 * (o.width - 1) + 6 * scale;
  k.cy = 0.5 * (o.height - 1) - 4 * scale;
  k.distortion = o.distortion;
  return k;
}

nlohmann::json pose_json(const Mat4& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

void check_options(const PhotoShootOptions& o) {
  check_board(o.board);
  if (o.photos < 1 || o.photos > 1000) throw Error("synth --photos: --views must be 1 to 1000");
  if (o.width < 64 || o.height < 48 || o.width > 8192 || o.height > 8192)
    throw Error("synth --photos: --size must be between 64x48 and 8192x8192");
  if (o.bracket.empty()) throw Error("synth --photos: the bracket needs at least one exposure");
  if (o.brdf != "truth" && o.brdf != "ggx")
    throw Error("synth --photos: --brdf must be truth or ggx, not '" + o.brdf + "'");
  if (o.brdf == "ggx" && (o.truth.maps.any() || o.truth.model != Model::kLine ||
                          o.truth.has_second_fiber || o.truth.has_isotropic))
    throw Error(
        "synth --photos: --brdf ggx renders one line-model material (k_d, k_s, n, psi); "
        "this material has maps, a second fiber, an isotropic term or is a fiber "
        "material");
  if (!(o.ggx_alpha_b > 0 && o.ggx_alpha_b <= 1))
    throw Error("synth --photos: --ggx-alpha-b must be in (0, 1]");
  if (!(o.vignetting > -0.8 && o.vignetting <= 0.5))
    throw Error("synth --photos: --vignetting must be in (-0.8, 0.5]");
  if (!(o.paper_albedo >= 0.3 && o.paper_albedo <= 1))
    throw Error("synth --photos: --paper-reflectance must be in [0.3, 1]");
  if (!(o.grey_card == 0 || (o.grey_card >= 0.02 && o.grey_card <= 1)))
    throw Error("synth --photos: --grey-card must be 0 (none) or in [0.02, 1]");
}

}  // namespace

void ggx_reflectance(const Material& m, double alpha_b, double Lu, double Lw, double Ln, double Vu,
                     double Vw, double Vn, double out[3]) {
  out[0] = out[1] = out[2] = 0;
  if (!(Ln > 0) || !(Vn > 0)) return;
  const double psi = m.fiber_angle_deg * M_PI / 180, c = std::cos(psi), sn = std::sin(psi);
  // Components along the fiber T = c U + sn W and across it, B = N x T = -sn U + c W.
  auto along = [&](double u, double w) { return c * u + sn * w; };
  auto across = [&](double u, double w) { return -sn * u + c * w; };
  const double at = std::sqrt(2 / (m.n + 2)), ab = alpha_b;
  double Hu = Lu + Vu, Hw = Lw + Vw, Hn = Ln + Vn;
  const double h = std::sqrt(Hu * Hu + Hw * Hw + Hn * Hn);
  Hu /= h, Hw /= h, Hn /= h;
  const double ht = along(Hu, Hw) / at, hb = across(Hu, Hw) / ab;
  const double q = ht * ht + hb * hb + Hn * Hn;
  const double D = 1 / (M_PI * at * ab * q * q);
  auto g1 = [&](double u, double w, double n) {
    const double t = along(u, w) * at, b = across(u, w) * ab;
    return 2 / (1 + std::sqrt(1 + (t * t + b * b) / (n * n)));
  };
  const double spec = D * g1(Lu, Lw, Ln) * g1(Vu, Vw, Vn) / (4 * Vn);  // f_r <N,L>
  for (int k = 0; k < 3; ++k) out[k] = m.kd[k] * Ln + m.ks[k] * spec;
}

PhotoShootStats simulate_photo_shoot(const PhotoShootOptions& o, const std::string& out_dir) {
  const auto t0 = std::chrono::steady_clock::now();
  check_options(o);
  const RayScene scene(shoot_scene(o));
  const BoardAlbedo board(o.board, o.paper_albedo);
  const Evaluator eval(o.truth);
  const Intrinsics k = shoot_camera(o);
  Vec3 centre{0, 0, 0};
  for (const auto& p : o.polygon) centre = centre + Vec3(p[0], p[1], 0) * (1.0 / o.polygon.size());
  centre.z = -o.height_m;
  // A white sheet at unit irradiance reads 0.68 of full scale in the longest exposure.
  const double base = 0.68 / (o.paper_albedo / M_PI);

  Shoot shoot;
  shoot.board = o.board;
  shoot.polygon = o.polygon;
  shoot.height_m = o.height_m;
  shoot.tangent = o.tangent;
  if (o.grey_card > 0) {
    const auto& c = o.card_m;
    shoot.reference.polygon = {{c[0], c[1]}, {c[2], c[1]}, {c[2], c[3]}, {c[0], c[3]}};
    shoot.reference.reflectance = {o.grey_card, o.grey_card, o.grey_card};
  }
  shoot.color.encoding =
      o.raw16 || o.dng ? ColorSpec::Encoding::kLinear : ColorSpec::Encoding::kSrgb;
  shoot.color.encoding_given = true;
  std::mt19937_64 rng(o.seed);
  std::vector<PhotoSetup> setups;
  for (int i = 0; i < o.photos; ++i) setups.push_back(photo_setup(o, i, centre, rng));

  // The lamps as the person writes them; truth.json keeps where they were.
  std::vector<std::vector<Light>> written;
  std::mt19937_64 tape(o.seed ^ 0x7a9e5eedULL);
  std::normal_distribution<double> off(0.0, 1.0);
  nlohmann::json lamps = nlohmann::json::array(), fills = nlohmann::json::array();
  for (const auto& su : setups) {
    written.emplace_back();
    for (const Light& truth : su.lamps) {
      Light l = truth;
      if (o.lamp_error_m > 0)
        for (double* v : {&l.position.x, &l.position.y, &l.position.z})
          *v += o.lamp_error_m * off(tape);
      // Never on the board's far side, as check_light requires of a shoot.
      l.position.z = std::min(l.position.z, -o.height_m - 0.05);
      if (o.hide_intensity) l.intensity = {1, 1, 1};
      written.back().push_back(l);
    }
    lamps.push_back({{"position_m", jsonu::to_json(su.lamps[0].position)},
                     {"intensity", jsonu::to_json(su.lamps[0].intensity)}});
    if (o.fill_lamp)
      fills.push_back({{"position_m", jsonu::to_json(su.lamps[1].position)},
                       {"intensity", jsonu::to_json(su.lamps[1].intensity)}});
  }

  PhotoShootStats st;
  write_folder_atomically(out_dir, OutputKind::kPhotoShoot, [&](const std::string& dir) {
    Progress bar("synth --photos: rendering", setups.size(), o.progress);
    nlohmann::json poses = nlohmann::json::array();
    for (int i = 0; i < o.photos; ++i) {
      const Image radiance = render_photo(o, k, scene, board, eval, setups[i], &st);
      ShootPhoto photo;
      photo.lights = written[i];
      photo.position_sigma_m.assign(photo.lights.size(),
                                    o.lamp_error_m > 0 ? o.lamp_error_m : kDefaultLampSigmaM);
      for (size_t e = 0; e < o.bracket.size(); ++e) {
        char name[64];
        std::snprintf(name, sizeof name, "photos/p%02d_e%zu.%s", i, e,
                      o.dng    ? "dng"
                      : o.jpeg ? "jpg"
                               : "png");
        const double exposure = base * o.bracket[e];
        const Image img =
            expose(o, radiance, exposure, i, static_cast<int>(e), &st.saturated_codes);
        if (o.dng)
          write_dng(join_path(dir, name), img,
                    o.bayer ? DngLayout::kBayerRggb : DngLayout::kLinear);
        else if (o.jpeg)
          write_jpeg(join_path(dir, name), img, 95);
        else
          write_png(join_path(dir, name), img, o.raw16 ? 16 : 8);
        photo.images.push_back({name, exposure});
        ++st.images;
      }
      shoot.photos.push_back(photo);
      poses.push_back(pose_json(setups[i].world_from_camera));
      bar.advance();
    }
    write_shoot(shoot, join_path(dir, "shoot.json"));
    nlohmann::json mat;
    material_to_json(o.truth, &mat);
    write_json_file(join_path(dir, "material.json"), mat);
    write_json_file(join_path(dir, "truth.json"), {{"format", "aniso-shoot-truth"},
                                                   {"version", 1},
                                                   {"seed", o.seed},
                                                   {"read_noise", o.read_noise},
                                                   {"camera", camera_json(k)},
                                                   {"world_from_camera", poses},
                                                   {"lamps", lamps},
                                                   {"fill_lamps", fills},
                                                   {"lamp_error_m", o.lamp_error_m},
                                                   {"intensity_hidden", o.hide_intensity},
                                                   {"brdf", o.brdf},
                                                   {"ggx_alpha_b", o.ggx_alpha_b},
                                                   {"paper_reflectance", o.paper_albedo},
                                                   {"grey_card", o.grey_card},
                                                   {"vignetting_a1", o.vignetting},
                                                   {"material", "material.json"}});
  });
  st.photos = setups.size();
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

}  // namespace aniso
