#include "render/verify.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/texture.h"
#include "io/files.h"
#include "io/image_io.h"
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

}  // namespace

VerifyResult verify_capture(const CaptureSet& set, const Material& m,
                            const std::string& residual_dir) {
  VerifyResult res;
  std::vector<Image> resids;  // --residuals: written together at the end
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
        const Evaluator local =
            m.maps.any() ? Evaluator(material_at(m, g.uv.px[2 * p], g.uv.px[2 * p + 1])) : eval;
        shade_point(local, sp, d.eye, v.lights, amb, topo, no_shadows, I, &cnt);
        double p2 = 0, pred = 0, obs = 0;
        for (int c = 0; c < 3; ++c) {
          const double err = v.exposure * I[c] - d.rgb.at(x, y, c);
          if (keep_residuals) resid.at(x, y, c) = static_cast<float>(err);
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
    if (keep_residuals) resids.push_back(std::move(resid));
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
  if (keep_residuals)  // one folder output, swapped in whole (io/files.h)
    write_folder_atomically(residual_dir, OutputKind::kResiduals, [&](const std::string& dir) {
      for (size_t i = 0; i < resids.size(); ++i) {
        char name[48];
        std::snprintf(name, sizeof name, "residual_%03zu.exr", i);
        write_exr(join_path(dir, name), resids[i]);
      }
    });
  const double n = 3.0 * std::max<size_t>(res.overall.pixels, 1);
  res.overall.rms = std::sqrt(sum2 / n);
  const size_t lit = res.overall.pixels - res.overall.dark;
  res.overall.rms_without_dark = lit ? std::sqrt(std::max(sum2 - sum2_dark, 0.0) / (3.0 * lit)) : 0;
  res.overall.mean_signal = sumy / n;
  return res;
}

}  // namespace aniso
