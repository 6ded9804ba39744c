// Reading one view of a capture set into per-pixel linear values and geometry (FORMAT.md):
// the image decoded by the set's colour statement, the geometry from buffers or a traced mesh,
// and every masked pixel sorted into usable, saturated or not finite.
#include <cmath>
#include <limits>

#include "core/color.h"
#include "core/error.h"
#include "core/texture.h"
#include "geometry/raycast.h"
#include "io/capture.h"
#include "io/files.h"
#include "io/image_io.h"

namespace aniso {

double decode_code(double v, const ColorSpec& c) {
  v -= c.black_level;
  switch (c.encoding) {
    case ColorSpec::Encoding::kLinear:
      return v;
    case ColorSpec::Encoding::kSrgb:
      return srgb_decode(v);
    case ColorSpec::Encoding::kGamma:
      return v < 0 ? -std::pow(-v, c.gamma) : std::pow(v, c.gamma);
  }
  return v;
}

namespace {

Image need_buffer(const std::string& path, int channels, const Intrinsics& k,
                  const std::string& what) {
  Image b = read_image(path, k.width, k.height).image;
  if (b.width != k.width || b.height != k.height)
    throw Error(path + ": " + what + " buffer is " + std::to_string(b.width) + "x" +
                std::to_string(b.height) + ", camera is " + std::to_string(k.width) + "x" +
                std::to_string(k.height));
  if (b.channels < channels)
    throw Error(path + ": " + what + " buffer needs " + std::to_string(channels) + " channels");
  return b;
}

}  // namespace

TopologyMap load_topology_map(const std::string& path) {
  TopologyMap m;
  const Image img = read_image(path).image;
  m.h = Image(img.width, img.height, 1);
  for (size_t p = 0; p < m.h.px.size(); ++p) {
    const float v = img.px[p * img.channels];
    if (!std::isfinite(v)) throw Error(path + ": topology map has a non-finite value");
    m.h.px[p] = v;
  }
  return m;
}

double TopologyMap::sample(double u, double v) const {
  const BilinearTaps t = bilinear_wrap(u, v, h.width, h.height);
  double val = 0;
  for (int k = 0; k < 4; ++k) val += t.weight[k] * h.px[t.index[k]];
  return 2.0 * val - 1.0;
}

namespace {

// The view's image, checked against the camera and the set's colour statement.
LoadedImage read_view_image(const CaptureSet& s, const ViewSpec& v, const std::string& ctx) {
  const Intrinsics& k = v.camera;
  const std::string img_path = join_path(s.dir, v.image);
  LoadedImage li;
  try {
    li = read_image(img_path, k.width, k.height);
  } catch (const Error& e) {
    throw Error(ctx + ".image: " + e.what());
  }
  const Image& raw = li.image;
  if (raw.channels != 1 && raw.channels != 3)
    throw Error(ctx + ".image: " + img_path + " has " + std::to_string(raw.channels) +
                " channels; a view is grey (1) or RGB (3)");
  if (li.bits != 0 && !s.color.encoding_given)
    throw Error(ctx + ".image: " + img_path + " is a " + std::to_string(li.bits) +
                "-bit integer image and " + s.file +
                " states no color.encoding: add \"color\": {\"encoding\": \"srgb\"} (most "
                "cameras and 8-bit exports) or \"linear\" (raw sensor data)");
  if (raw.width != k.width || raw.height != k.height)
    throw Error(ctx + ".image: " + img_path + " is " + std::to_string(raw.width) + "x" +
                std::to_string(raw.height) + ", camera is " + std::to_string(k.width) + "x" +
                std::to_string(k.height));
  return li;
}

// Per-pixel geometry from the view's buffers: P, N, U, the mask, s_math, uv and the topology
// map's value at uv.
void read_geometry_buffers(const CaptureSet& s, const ViewSpec& v, const TopologyMap* map,
                           ViewData* d, std::vector<uint8_t>* mask) {
  const Intrinsics& k = v.camera;
  const GeometrySpec& g = v.geometry;
  d->P = need_buffer(join_path(s.dir, g.position), 3, k, "position");
  d->N = need_buffer(join_path(s.dir, g.normal), 3, k, "normal");
  d->U = need_buffer(join_path(s.dir, g.tangent), 3, k, "tangent");
  if (!g.mask.empty()) {
    const Image m = need_buffer(join_path(s.dir, g.mask), 1, k, "mask");
    for (size_t p = 0; p < mask->size(); ++p) (*mask)[p] = m.px[p * m.channels] != 0.f;
  }
  if (!g.topology.empty()) {
    const Image t = need_buffer(join_path(s.dir, g.topology), 1, k, "topology");
    for (size_t p = 0; p < mask->size(); ++p) {
      const float val = t.px[p * t.channels];
      if ((*mask)[p] && !(val >= 0.f && val <= 1.f))
        throw Error(join_path(s.dir, g.topology) + ": topology value " + std::to_string(val) +
                    " outside [0, 1]");
      d->smath.px[p] = val;
    }
  }
  if (!g.uv.empty()) {
    const Image uv = need_buffer(join_path(s.dir, g.uv), 2, k, "uv");
    d->uv = Image(k.width, k.height, 2);
    for (size_t p = 0; p < mask->size(); ++p)
      for (int c = 0; c < 2; ++c) d->uv.px[2 * p + c] = uv.px[p * uv.channels + c];
  }
  if (!map) return;
  if (d->uv.empty()) throw Error("a topology map needs the \"uv\" buffer");
  for (size_t p = 0; p < mask->size(); ++p)
    if ((*mask)[p] && std::isfinite(d->uv.px[2 * p]) && std::isfinite(d->uv.px[2 * p + 1]))
      d->mapv.px[p] = static_cast<float>(map->sample(d->uv.px[2 * p], d->uv.px[2 * p + 1]));
}

// Decodes the masked pixels to linear and sorts them: usable, saturated or not finite (value or
// geometry).
void classify_pixels(const CaptureSet& s, const LoadedImage& li, const std::vector<uint8_t>& mask,
                     ViewData* d) {
  const Image& raw = li.image;
  const int w = raw.width, h = raw.height;
  const double sat = s.color.saturation_given
                         ? s.color.saturation
                         : (li.bits ? 1.0 : std::numeric_limits<double>::infinity());
  d->rgb = Image(w, h, 3);
  d->use.assign(mask.size(), 0);
  auto finite3 = [](const Image& im, int x, int y) {
    return std::isfinite(im.at(x, y, 0)) && std::isfinite(im.at(x, y, 1)) &&
           std::isfinite(im.at(x, y, 2));
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (!mask[p]) continue;
      ++d->mask_pixels;
      bool ok = true, saturated = false;
      for (int c = 0; c < 3; ++c) {
        const float r = raw.at(x, y, raw.channels == 3 ? c : 0);
        if (!std::isfinite(r))
          ok = false;
        else if (r >= sat)
          saturated = true;
        const double lin = li.bits ? decode_code(r, s.color) : r;
        if (!std::isfinite(lin) || std::abs(lin) > std::numeric_limits<float>::max()) ok = false;
        d->rgb.at(x, y, c) = static_cast<float>(lin);
      }
      if (!d->uv.empty() &&
          (!std::isfinite(d->uv.at(x, y, 0)) || !std::isfinite(d->uv.at(x, y, 1))))
        ok = false;
      if (!finite3(d->P, x, y) || !finite3(d->N, x, y) || !finite3(d->U, x, y)) ok = false;
      if (!ok) {
        ++d->nonfinite;
        continue;
      }
      if (saturated) {
        ++d->saturated;
        continue;
      }
      d->use[p] = 1;
      ++d->used;
    }
}

}  // namespace

ViewData load_view(const CaptureSet& s, size_t i, const TopologyMap* map, GeometryCache* cache) {
  const ViewSpec& v = s.views.at(i);
  const Intrinsics& k = v.camera;
  const std::string ctx = s.file + ": views[" + std::to_string(i) + "]";
  ViewData d;
  d.eye = v.world_from_camera.translation();
  const LoadedImage li = read_view_image(s, v, ctx);
  d.channels = li.image.channels;
  std::vector<uint8_t> mask(static_cast<size_t>(k.width) * k.height, 1);
  const GeometrySpec& g = v.geometry;
  const std::string key = g.position + '\n' + g.normal + '\n' + g.tangent + '\n' + g.mask + '\n' +
                          g.topology + '\n' + g.uv + '\n' + std::to_string(k.width) + 'x' +
                          std::to_string(k.height);
  const bool cached = g.mesh.empty() && cache && cache->held && cache->key == key;
  if (!cached) {
    d.smath = Image(k.width, k.height, 1, 0.f);
    d.mapv = Image(k.width, k.height, 1, 0.f);
  }
  if (!g.mesh.empty()) {
    try {
      trace_mesh_gbuffer(join_path(s.dir, g.mesh), g.fiber_field, k, v.world_from_camera, &d.P,
                         &d.N, &d.U, &mask);
    } catch (const Error& e) {
      throw Error(ctx + ".geometry.mesh: " + e.what());
    }
  } else {
    if (cached) {  // lent, not copied: give_back_geometry returns them
      d.P = std::move(cache->P), d.N = std::move(cache->N), d.U = std::move(cache->U);
      d.smath = std::move(cache->smath), d.mapv = std::move(cache->mapv);
      d.uv = std::move(cache->uv);
      mask = cache->mask;
      cache->held = false;
    } else {
      try {
        read_geometry_buffers(s, v, map, &d, &mask);
      } catch (const Error& e) {
        throw Error(ctx + ".geometry: " + e.what());
      }
      if (cache)
        *cache =
            GeometryCache{key, Image(), Image(), Image(), Image(), Image(), Image(), mask, false};
    }
  }
  classify_pixels(s, li, mask, &d);
  return d;
}

void give_back_geometry(ViewData* d, GeometryCache* cache) {
  if (cache->key.empty() || cache->held) return;
  cache->P = std::move(d->P), cache->N = std::move(d->N), cache->U = std::move(d->U);
  cache->smath = std::move(d->smath), cache->mapv = std::move(d->mapv);
  cache->uv = std::move(d->uv);
  cache->held = true;
}

}  // namespace aniso
