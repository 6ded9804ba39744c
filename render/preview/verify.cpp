#include "render/preview/verify.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/error.h"
#include "core/noise.h"
#include "core/texture.h"
#include "io/files/files.h"
#include "io/images/image_io.h"
#include "models/material_maps.h"
#include "models/shade.h"
#include "models/topology.h"

namespace aniso {

namespace {

// A material with maps, or a map of s, is read at each pixel's texture coordinates.
void check_uv(const CaptureSet& set, size_t i, const ViewGeometry& g, bool maps, bool s_map) {
  if (s_map && g.uv.empty())
    throw Error(set.file + ": the material's map of s needs the \"uv\" buffer");
  if (maps && g.uv.empty())
    throw Error(set.file + ": views[" + std::to_string(i) +
                "]: the material has maps (k_d, k_s, n or fiber over uv); the view needs the "
                "\"uv\" buffer");
}

// One channel's noise sigma of an image over its usable pixels, from second differences along
// rows where x - 1, x and x + 1 are all usable (the fit's measure: core/noise.h).
double image_noise(const ViewData& d, int channel) {
  std::vector<float> diffs;
  const int w = d.rgb.width;
  for (int y = 0; y < d.rgb.height; ++y)
    for (int x = 1; x + 1 < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (!d.usable(p - 1) || !d.usable(p) || !d.usable(p + 1)) continue;
      diffs.push_back(d.rgb.at(x - 1, y, channel) - 2 * d.rgb.at(x, y, channel) +
                      d.rgb.at(x + 1, y, channel));
    }
  return second_difference_noise(&diffs);
}

// The residual picture: green's residual over the noise, blue (-3 sigma) - white - red (+3).
Image residual_picture(const Image& resid, const std::vector<uint8_t>& on, double noise) {
  Image out(resid.width, resid.height, 3, 0.5f);
  const double scale = noise > 0 ? 1 / (3 * noise) : 0;
  for (size_t p = 0; p < on.size(); ++p) {
    if (!on[p]) continue;
    const float t = static_cast<float>(std::clamp(resid.px[3 * p + 1] * scale, -1.0, 1.0));
    out.px[3 * p] = t < 0 ? 1 + t : 1;
    out.px[3 * p + 1] = 1 - std::abs(t);
    out.px[3 * p + 2] = t > 0 ? 1 - t : 1;
  }
  return out;
}

// The view's image and the model's on the sample (dark grey elsewhere), sRGB, both at one
// exposure: the image's 99.5th percentile on the sample as white.
std::pair<Image, Image> view_and_model_pictures(const Image& rgb, const Image& model,
                                                const std::vector<uint8_t>& on) {
  std::vector<float> values;
  for (size_t p = 0; p < on.size(); ++p)
    if (on[p])
      for (int c = 0; c < 3; ++c) values.push_back(rgb.px[3 * p + c]);
  double white = 1;
  if (!values.empty()) {
    const size_t k = values.size() * 995 / 1000;
    std::nth_element(values.begin(), values.begin() + k, values.end());
    if (values[k] > 0) white = values[k];
  }
  Image a(rgb.width, rgb.height, 3, 0.2f), b = a;
  for (size_t p = 0; p < on.size(); ++p)
    if (on[p])
      for (int c = 0; c < 3; ++c) {
        a.px[3 * p + c] =
            static_cast<float>(srgb_encode(std::clamp(rgb.px[3 * p + c] / white, 0.0, 1.0)));
        b.px[3 * p + c] =
            static_cast<float>(srgb_encode(std::clamp(model.px[3 * p + c] / white, 0.0, 1.0)));
      }
  return {std::move(a), std::move(b)};
}

}  // namespace

VerifySamples::Lobe VerifySamples::lobe_at(const LocalDir& L, const LocalDir& V, double psi_deg,
                                           double data, double model) {
  const double c = std::cos(deg_to_rad(psi_deg)), s = std::sin(deg_to_rad(psi_deg));
  const double hu = L.u + V.u, hw = L.w + V.w, hn = L.n + V.n;
  const double h = std::max(std::sqrt(hu * hu + hw * hw + hn * hn), 1e-300);
  return {static_cast<float>(c * L.u + s * L.w),
          static_cast<float>(c * V.u + s * V.w),
          static_cast<float>((c * hu + s * hw) / h),
          static_cast<float>((c * hw - s * hu) / h),
          static_cast<float>(data),
          static_cast<float>(model)};
}

void VerifySamples::reflectance_and_diffuse(const Material& at, const LocalDir& L,
                                            const LocalDir& V, double s, double* f, double* fd) {
  Material diffuse = at;
  diffuse.maps = MaterialMaps{};
  diffuse.ks = {0, 0, 0};
  diffuse.iso_ks = {0, 0, 0};
  double full[3], part[3];
  const Evaluator whole(at), without_lobes(diffuse);
  whole(L, V, full, s);
  without_lobes(L, V, part, s);
  *f = full[1], *fd = part[1];
}

const char* verdict(double r) {
  return r <= 0     ? "no noise measure"
         : r <= 1.5 ? "at the noise"
         : r <= 3   ? "near the noise"
                    : "misfit";
}

namespace {

// One pixel's sample of the lobe (VerifySamples::Lobe), if one light lit it.
bool lobe_sample(const Material& at, const SurfacePoint& sp, const Vec3& eye, const Light& light,
                 double topo, double observed, double exposure, double ambient,
                 VerifySamples::Lobe* out) {
  Vec3 L;
  RGB E;
  double dist;
  if (!light_at(light, sp.P, &L, &E, &dist) || !(E[1] > 0) || !(exposure > 0)) return false;
  const LocalDir Ll = to_local(sp, L), Vl = to_local(sp, normalize(eye - sp.P));
  double f, fd;
  VerifySamples::reflectance_and_diffuse(at, Ll, Vl, topo, &f, &fd);
  *out = VerifySamples::lobe_at(Ll, Vl, at.fiber_angle_deg,
                                (observed / exposure - ambient) / E[1] - fd, f - fd);
  return std::isfinite(out->data) && std::isfinite(out->model);
}

}  // namespace

VerifyResult verify_capture(const CaptureSet& set, const Material& m,
                            const std::string& residual_dir, VerifySamples* samples) {
  VerifyResult res;
  std::vector<Image> resids;  // --residuals: written together at the end
  std::vector<Image> pictures, view_images, model_images;
  const Evaluator eval(m);
  double sum2 = 0, sumy = 0, sum2_dark = 0;
  std::vector<float> green;  // |error| of one channel per pixel, for the noise: reused view to view
  auto no_shadows = [](const SurfacePoint&, const Vec3&, double, ShadeCounters*) { return false; };
  TopologyMap map;
  // The material's own maps (paths relative to the material file).
  const auto* map_ref = m.fiber() ? m.topology_as<TopologyMapRef>() : nullptr;
  const bool use_map = map_ref != nullptr;
  if (use_map) map = load_topology_map(join_path(m.base_dir, map_ref->file));
  Image s_map;  // a per-texel map of s (what `fit --topology-map` writes), R channel
  if (const auto* s = m.fiber() ? m.topology_as<SMapRef>() : nullptr)
    s_map = read_image(join_path(m.base_dir, s->file)).image;
  GeometryCache geometry;
  // Each view decoded into the allocation of the one before (a 2048^2 view is 48 MB of fresh
  // pages otherwise), and a residual image only where --residuals asks for them.
  ExrReadBuffers buffers;
  const bool keep_residuals = !residual_dir.empty();
  for (size_t i = 0; i < set.views.size(); ++i) {
    ViewData d = load_view(set, i, use_map ? &map : nullptr, &geometry);
    const ViewGeometry& g = *d.geo;
    check_uv(set, i, g, m.maps.any(), !s_map.empty());
    const ViewSpec& v = set.views[i];
    ViewError e;
    double s2 = 0, sy = 0, predicted = 0;
    struct Dark {
      double predicted, deficit, err2;  // summed over the channels
    };
    std::vector<Dark> darker;  // pixels under a quarter of the prediction (few in a good fit)
    green.clear();
    Image resid = keep_residuals ? Image(d.rgb.width, d.rgb.height, 3, 0.f) : Image();
    std::vector<uint8_t> on(keep_residuals ? static_cast<size_t>(d.rgb.width) * d.rgb.height : 0);
    const bool view_pictures = keep_residuals && samples && samples->view_pictures;
    Image model = view_pictures ? Image(d.rgb.width, d.rgb.height, 3, 0.f) : Image();
    e.noise = image_noise(d, 1);
    // Every k-th usable pixel a lobe sample, k spreading max_lobe evenly over the views.
    size_t stride = 0, seen = 0;
    if (samples) {
      size_t usable = 0;
      for (size_t p = 0; p < static_cast<size_t>(d.rgb.width) * d.rgb.height; ++p)
        usable += d.usable(p) ? 1 : 0;
      const size_t per_view = std::max<size_t>(1, samples->max_lobe / set.views.size());
      stride = std::max<size_t>(1, (usable + per_view - 1) / per_view);
    }
    std::vector<uint8_t> used(v.lights.size());
    ShadeCounters cnt;
    const RGB amb{m.ka[0] * set.ambient[0], m.ka[1] * set.ambient[1], m.ka[2] * set.ambient[2]};
    for (int y = 0; y < d.rgb.height; ++y)
      for (int x = 0; x < d.rgb.width; ++x) {
        if (!d.usable(static_cast<size_t>(y) * d.rgb.width + x)) continue;
        SurfacePoint sp;
        if (!frame_at(g.P, g.N, g.U, x, y, &sp)) continue;
        double I[3];
        const size_t p = static_cast<size_t>(y) * d.rgb.width + x;
        const double mv = s_map.empty()
                              ? g.mapv_at(p)
                              : sample_first_channel(s_map, g.uv.px[2 * p], g.uv.px[2 * p + 1]);
        // (check_uv: a material with maps has the pixel's texture coordinates)
        const double topo = m.maps.any()
                                ? s_at(m, g.smath_at(p), mv, g.uv.px[2 * p], g.uv.px[2 * p + 1])
                                : s_at(m, g.smath_at(p), mv);
        // A material with maps: its values at the pixel's texture coordinates.
        std::optional<Material> here;
        if (m.maps.any()) here = material_at(m, g.uv.px[2 * p], g.uv.px[2 * p + 1]);
        const Evaluator local = here ? Evaluator(*here) : eval;
        if (samples) std::fill(used.begin(), used.end(), 0);
        shade_point(local, sp, d.eye, v.lights, amb, topo, no_shadows, I, &cnt,
                    samples ? &used : nullptr);
        if (samples) {
          if (e.noise > 0) samples->add_residual((v.exposure * I[1] - d.rgb.at(x, y, 1)) / e.noise);
          VerifySamples::Lobe s;
          if (seen++ % stride == 0 && std::count(used.begin(), used.end(), 1) == 1 &&
              samples->lobe.size() < samples->max_lobe) {
            const size_t li = std::find(used.begin(), used.end(), 1) - used.begin();
            if (lobe_sample(here ? *here : m, sp, d.eye, v.lights[li], topo, d.rgb.at(x, y, 1),
                            v.exposure, amb[1], &s))
              samples->lobe.push_back(s);
          }
        }
        double p2 = 0, pred = 0, obs = 0;
        for (int c = 0; c < 3; ++c) {
          const double err = v.exposure * I[c] - d.rgb.at(x, y, c);
          if (keep_residuals) resid.at(x, y, c) = static_cast<float>(err), on[p] = 1;
          if (view_pictures) model.at(x, y, c) = static_cast<float>(v.exposure * I[c]);
          p2 += err * err;
          pred += v.exposure * I[c], obs += d.rgb.at(x, y, c);
          sy += std::abs(d.rgb.at(x, y, c));
          e.max_abs = std::max(e.max_abs, std::abs(err));
        }
        s2 += p2;
        predicted += pred;
        if (obs < 0.25 * pred) darker.push_back({pred, pred - obs, p2});
        green.push_back(static_cast<float>(std::abs(v.exposure * I[1] - d.rgb.at(x, y, 1))));
        ++e.pixels;
      }
    res.light_evals += cnt.light_evals;
    if (view_pictures) {
      auto [image, predicted_image] = view_and_model_pictures(d.rgb, model, on);
      view_images.push_back(std::move(image)), model_images.push_back(std::move(predicted_image));
    }
    if (keep_residuals) {
      pictures.push_back(residual_picture(resid, on, e.noise));
      resids.push_back(std::move(resid));
    }
    buffers.give_back(std::move(d.rgb));
    e.rms = e.pixels ? std::sqrt(s2 / (3.0 * e.pixels)) : 0;
    // Dark beyond the noise: a deficit over 5 sigma of the three channels' sum, sigma robust from
    // the view's residuals (the median |error| of one channel; shadows are a few pixels of many).
    double sigma = 0;
    if (!green.empty()) {
      std::nth_element(green.begin(), green.begin() + green.size() / 2, green.end());
      sigma = 1.4826 * green[green.size() / 2];
    }
    double s2_dark = 0;
    for (const Dark& k : darker)
      if (k.predicted > 0.1 * predicted / std::max<size_t>(e.pixels, 1) &&
          k.deficit > 5 * std::sqrt(3.0) * sigma)
        ++e.dark, s2_dark += k.err2;
    e.rms_without_dark = e.pixels > e.dark
                             ? std::sqrt(std::max(s2 - s2_dark, 0.0) / (3.0 * (e.pixels - e.dark)))
                             : 0;
    res.overall.dark += e.dark;
    sum2_dark += s2_dark;
    e.mean_signal = e.pixels ? sy / (3.0 * e.pixels) : 0;
    res.views.push_back(e);
    sum2 += s2;
    sumy += sy;
    res.overall.pixels += e.pixels;
    res.overall.max_abs = std::max(res.overall.max_abs, e.max_abs);
  }
  if (keep_residuals)  // one folder output, swapped in whole (io/files/files.h)
    write_folder_atomically(residual_dir, OutputKind::kResiduals, [&](const std::string& dir) {
      for (size_t i = 0; i < resids.size(); ++i) {
        char name[48];
        std::snprintf(name, sizeof name, "residual_%03zu.exr", i);
        write_exr(join_path(dir, name), resids[i]);
        std::snprintf(name, sizeof name, "residual_%03zu.png", i);
        write_png(join_path(dir, name), pictures[i], 8);
        if (i < view_images.size()) {
          std::snprintf(name, sizeof name, "image_%03zu.png", i);
          write_png(join_path(dir, name), view_images[i], 8);
          std::snprintf(name, sizeof name, "model_%03zu.png", i);
          write_png(join_path(dir, name), model_images[i], 8);
        }
      }
    });
  std::vector<double> noises;
  for (const ViewError& v : res.views)
    if (v.noise > 0) noises.push_back(v.noise);
  if (!noises.empty()) {
    std::nth_element(noises.begin(), noises.begin() + noises.size() / 2, noises.end());
    res.overall.noise = noises[noises.size() / 2];
  }
  const double n = 3.0 * std::max<size_t>(res.overall.pixels, 1);
  res.overall.rms = std::sqrt(sum2 / n);
  const size_t lit = res.overall.pixels - res.overall.dark;
  res.overall.rms_without_dark = lit ? std::sqrt(std::max(sum2 - sum2_dark, 0.0) / (3.0 * lit)) : 0;
  res.overall.mean_signal = sumy / n;
  return res;
}

}  // namespace aniso
