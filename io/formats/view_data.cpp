// Reading one view of a capture set into per-pixel linear values and geometry (docs/formats.md):
// the image decoded by the set's colour statement, the geometry from buffers or a traced mesh,
// and every masked pixel sorted into usable, saturated or not finite.
#include <immintrin.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <mutex>

#include "core/color.h"
#include "core/cpu.h"
#include "core/error.h"
#include "core/texture.h"
#include "geometry/raycast.h"
#include "io/files/files.h"
#include "io/formats/capture.h"
#include "io/images/image_io.h"

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

// g->rows: 1 for each row of a w x h mask that holds a sample pixel (every row where the mask is
// not w x h); g->mask_count: the mask's pixels.
void mask_rows(int w, int h, ViewGeometry* g) {
  const std::vector<uint8_t>& mask = g->mask;
  g->rows.assign(static_cast<size_t>(h), 1);
  g->mask_count = static_cast<size_t>(
      std::count_if(mask.begin(), mask.end(), [](uint8_t b) { return b != 0; }));
  if (mask.size() != static_cast<size_t>(w) * h) return;
  for (int y = 0; y < h; ++y) {
    const uint8_t* m = mask.data() + static_cast<size_t>(y) * w;
    g->rows[y] = std::any_of(m, m + w, [](uint8_t b) { return b != 0; });
  }
}

// `rows`: only those rows are read (where the file allows; the others 0, or as the reused
// allocation left them without `zero_others`).
Image need_buffer(const std::string& path, int channels, const Intrinsics& k,
                  const std::string& what, const std::vector<uint8_t>* rows = nullptr,
                  bool zero_others = true) {
  Image b = read_image(path, k.width, k.height, rows, zero_others).image;
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
LoadedImage read_view_image(const CaptureSet& s, const ViewSpec& v, const std::string& ctx,
                            const std::vector<uint8_t>* rows, bool zero_others) {
  const Intrinsics& k = v.camera;
  const std::string img_path = join_path(s.dir, v.image);
  LoadedImage li;
  try {
    li = read_image(img_path, k.width, k.height, rows, zero_others);
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

// Calls f(p) for every pixel p of rows [y0, y1) that g.rows holds (every pixel without
// `only_rows`).
template <class F>
void for_rows_in(const ViewGeometry& g, bool only_rows, size_t y0, size_t y1, F f) {
  const size_t w = g.rows.empty() ? 0 : g.mask.size() / g.rows.size();
  for (size_t y = y0; y < y1; ++y)
    if (!only_rows || g.rows[y])
      for (size_t p = y * w, end = p + w; p < end; ++p) f(p);
}
// ... of every row.
template <class F>
void for_rows(const ViewGeometry& g, bool only_rows, F f) {
  for_rows_in(g, only_rows, 0, g.rows.size(), f);
}

// g->finite: 1 where the pixel's position, normal, tangent (and uv, where the set has one) are
// finite. Once per geometry, where every view sharing it checked the same ten values again.
// With `only_rows`, in g->rows alone (0 elsewhere: the buffers hold no values there).
void mark_finite(bool only_rows, ViewGeometry* g) {
  auto finite3 = [](const Image& im, size_t p) {  // a buffer may hold more than three channels
    const float* v = &im.px[p * im.channels];
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
  };
  g->finite.assign(g->mask.size(), 0);
  // Rows side by side, 64 at a time (a fixed camera's 2048^2 geometry: 4 M pixels before any view
  // is read).
  constexpr size_t kRows = 64;
  tbb::parallel_for(size_t{0}, g->rows.size(), kRows, [&](size_t y0) {
    for_rows_in(*g, only_rows, y0, std::min(y0 + kRows, g->rows.size()), [&](size_t p) {
      g->finite[p] = (g->uv.empty() ||
                      (std::isfinite(g->uv.px[2 * p]) && std::isfinite(g->uv.px[2 * p + 1]))) &&
                     finite3(g->P, p) && finite3(g->N, p) && finite3(g->U, p);
    });
  });
}

// Per-pixel geometry from the view's buffers: P, N, U, the mask, s_math, uv and the topology
// map's value at uv. With `only_rows` (one entry per row): the buffers other than the mask are
// read in those rows alone (of the mask's), their other rows not written (a reused allocation's
// old values: nothing reads them), and g.rows says which were read.
ViewGeometry read_geometry_buffers(const CaptureSet& s, const ViewSpec& v, const TopologyMap* map,
                                   const std::vector<uint8_t>* only_rows = nullptr,
                                   bool uv_alone = false) {
  const Intrinsics& k = v.camera;
  const GeometrySpec& g = v.geometry;
  ViewGeometry d;
  d.mask.assign(static_cast<size_t>(k.width) * k.height, 1);
  // The mask first: the buffers' rows without a sample pixel are not read (nothing reads a pixel
  // off the mask; they hold 0).
  if (!g.mask.empty()) {
    const Image m = need_buffer(join_path(s.dir, g.mask), 1, k, "mask");
    for (size_t p = 0; p < d.mask.size(); ++p) d.mask[p] = m.px[p * m.channels] != 0.f;
  }
  mask_rows(k.width, k.height, &d);
  const bool part = only_rows != nullptr;
  if (part) {
    if (only_rows->size() != d.rows.size()) throw Error("the rows asked for are not the buffers'");
    for (size_t y = 0; y < d.rows.size(); ++y) d.rows[y] = d.rows[y] && (*only_rows)[y];
  }
  auto buffer = [&](const std::string& file, int channels, const char* what) {
    return need_buffer(join_path(s.dir, file), channels, k, what, &d.rows, !part);
  };
  auto read_uv = [&] {
    if (g.uv.empty()) return;
    Image uv = buffer(g.uv, 2, "uv");
    if (uv.channels == 2) {
      d.uv = std::move(uv);
    } else {
      d.uv = Image(k.width, k.height, 2);
      for_rows(d, part, [&](size_t p) {
        for (int c = 0; c < 2; ++c) d.uv.px[2 * p + c] = uv.px[p * uv.channels + c];
      });
    }
  };
  if (uv_alone) {
    read_uv();
    return d;
  }
  auto read_topology = [&] {
    if (g.topology.empty()) return;
    const Image t = buffer(g.topology, 1, "topology");
    d.smath = Image(k.width, k.height, 1, 0.f);
    for_rows(d, part, [&](size_t p) {
      const float val = t.px[p * t.channels];
      if (d.mask[p] && !(val >= 0.f && val <= 1.f))
        throw Error(join_path(s.dir, g.topology) + ": topology value " + std::to_string(val) +
                    " outside [0, 1]");
      d.smath.px[p] = val;
    });
  };
  // Position, normal, tangent, topology and uv decoded side by side (each its own file and
  // image: one after the other they held one core before any view was read); a failure is
  // reported as the serial order would have met it first.
  std::exception_ptr failed[5];
  tbb::parallel_for(0, 5, [&](int i) {
    try {
      if (i == 0) d.P = buffer(g.position, 3, "position");
      if (i == 1) d.N = buffer(g.normal, 3, "normal");
      if (i == 2) d.U = buffer(g.tangent, 3, "tangent");
      if (i == 3) read_topology();
      if (i == 4) read_uv();
    } catch (...) {
      failed[i] = std::current_exception();
    }
  });
  for (const auto& e : failed)
    if (e) std::rethrow_exception(e);
  mark_finite(part, &d);
  if (!map) return d;
  if (d.uv.empty()) throw Error("a topology map needs the \"uv\" buffer");
  d.mapv = Image(k.width, k.height, 1, 0.f);
  for_rows(d, part, [&](size_t p) {
    if (d.mask[p] && std::isfinite(d.uv.px[2 * p]) && std::isfinite(d.uv.px[2 * p + 1]))
      d.mapv.px[p] = static_cast<float>(map->sample(d.uv.px[2 * p], d.uv.px[2 * p + 1]));
  });
  return d;
}

// Sixteen pixels of classify_float_row at once (AVX-512 F, BW, VL and BMI2): each of the 48
// values' tests as a bit, three bits a pixel joined (finite: all three; saturated: any) and
// gathered to one a pixel by pext; the states stored as bytes under masks, the values off the
// mask zeroed under their own. The same states, counts and values as the scalar loop.
ANISO_AVX512BW void classify16(float* v, const uint8_t* mask, const uint8_t* finite, float sat_f,
                               uint8_t* use, size_t* on, size_t* bad, size_t* saturated) {
  const __m512 max = _mm512_set1_ps(std::numeric_limits<float>::max());
  const __m512 sat = _mm512_set1_ps(sat_f);
  uint64_t fin = 0, hot = 0;
  __m512 vals[3];
  for (int k = 0; k < 3; ++k) {
    vals[k] = _mm512_loadu_ps(v + 16 * k);
    fin |= uint64_t{_mm512_cmp_ps_mask(_mm512_abs_ps(vals[k]), max, _CMP_LE_OQ)} << (16 * k);
    hot |= uint64_t{_mm512_cmp_ps_mask(vals[k], sat, _CMP_GE_OQ)} << (16 * k);
  }
  constexpr uint64_t kEveryThird = 0x249249249249;  // bit 3k: pixel k's first value
  const auto px_fin = static_cast<uint16_t>(_pext_u64(fin & (fin >> 1) & (fin >> 2), kEveryThird));
  const auto px_hot = static_cast<uint16_t>(_pext_u64(hot | (hot >> 1) | (hot >> 2), kEveryThird));
  const __m128i zero = _mm_setzero_si128();
  const __mmask16 m =
      _mm_cmpneq_epi8_mask(_mm_loadu_si128(reinterpret_cast<const __m128i*>(mask)), zero);
  const __mmask16 geo =
      _mm_cmpneq_epi8_mask(_mm_loadu_si128(reinterpret_cast<const __m128i*>(finite)), zero);
  const __mmask16 ok = m & px_fin & geo, nonfinite = m & ~(px_fin & geo);
  const __mmask16 usable = ok & ~px_hot, hot_ok = ok & px_hot;
  __m128i states = _mm_maskz_mov_epi8(usable, _mm_set1_epi8(ViewData::kUsable));
  states = _mm_mask_mov_epi8(states, hot_ok, _mm_set1_epi8(ViewData::kSaturated));
  states = _mm_mask_mov_epi8(states, nonfinite, _mm_set1_epi8(ViewData::kNonfinite));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(use), states);
  const uint64_t keep3 = _pdep_u64(m, kEveryThird) * 7;  // each pixel's bit to its three values
  for (int k = 0; k < 3; ++k)
    _mm512_storeu_ps(v + 16 * k,
                     _mm512_maskz_mov_ps(static_cast<__mmask16>(keep3 >> (16 * k)), vals[k]));
  *on += static_cast<size_t>(__builtin_popcount(m));
  *bad += static_cast<size_t>(__builtin_popcount(nonfinite));
  *saturated += static_cast<size_t>(__builtin_popcount(hot_ok));
}

// classify_pixels' loop for row y of a float RGB image as it was decoded (d->rgb): the same
// states, counts and zeros off the mask, without a branch per pixel (the loop's branches were
// most of a band's classifying). `sat` as there: a value at or above it is saturated; compared
// in float at the least float not below it, which is the same test.
void classify_float_row(double sat, const ViewGeometry& g, int y, bool lanes, ViewData* d) {
  const int w = d->rgb.width;
  const size_t row = static_cast<size_t>(y) * w;
  float sat_f = static_cast<float>(sat);
  if (static_cast<double>(sat_f) < sat) sat_f = std::nextafter(sat_f, INFINITY);
  const uint8_t* mask = g.mask.data() + row;
  const uint8_t* finite = g.finite.data() + row;
  uint8_t* use = d->use.data() + row;
  float* v = d->rgb.px.data() + 3 * row;
  constexpr float kMax = std::numeric_limits<float>::max();
  size_t on = 0, bad = 0, saturated = 0;
  int x = 0;
  if (lanes && cpu_has_avx512_bw_vl_bmi2())
    for (; x + 16 <= w; x += 16)
      classify16(v + 3 * x, mask + x, finite + x, sat_f, use + x, &on, &bad, &saturated);
  for (; x < w; ++x) {
    float* c = v + 3 * x;
    const bool m = mask[x] != 0;
    // |value| <= max: finite (false for NaN and Inf)
    const bool fin = (std::abs(c[0]) <= kMax) & (std::abs(c[1]) <= kMax) & (std::abs(c[2]) <= kMax);
    const bool ok = fin & (finite[x] != 0);
    const bool sat_px = (c[0] >= sat_f) | (c[1] >= sat_f) | (c[2] >= sat_f);
    for (int k = 0; k < 3; ++k) c[k] = m ? c[k] : 0.f;
    use[x] = !m       ? ViewData::kOff
             : !ok    ? ViewData::kNonfinite
             : sat_px ? ViewData::kSaturated
                      : ViewData::kUsable;
    on += m, bad += m & !ok, saturated += m & ok & sat_px;
  }
  d->mask_pixels += on;
  d->nonfinite += bad;
  d->saturated += saturated;
  d->used += on - bad - saturated;
}

// Decodes the masked pixels of the rows d->rows to linear and sorts them: usable, saturated or
// not finite (value or geometry). An RGB image is decoded in place (no second copy of the view);
// pixels outside the mask read 0. `all_rows`: every row is looked at (rows not read hold 0).
void classify_pixels(const CaptureSet& s, LoadedImage li, bool all_rows, bool lanes, ViewData* d) {
  const ViewGeometry& g = *d->geo;
  const std::vector<uint8_t>& mask = g.mask;
  const Image& raw = li.image;
  const int w = raw.width, h = raw.height;
  const double sat = s.color.saturation_given
                         ? s.color.saturation
                         : (li.bits ? 1.0 : std::numeric_limits<double>::infinity());
  Image grey;  // a grey image is read from here into the three channels
  if (li.image.channels == 3) {
    d->rgb = std::move(li.image);
  } else {
    grey = std::move(li.image);
    d->rgb = Image(w, h, 3);
  }
  const Image& in = grey.empty() ? d->rgb : grey;
  // Empty, or all kOff (load_view_into): the rows not read stay kOff without being written.
  if (d->use.size() != mask.size()) d->use.assign(mask.size(), ViewData::kOff);
  // A float RGB image is linear as it is: its values stay where they were decoded.
  const bool as_is = li.bits == 0 && in.channels == 3;
  if (as_is) {
    for (int y = 0; y < h; ++y)
      if (all_rows || d->rows[y]) classify_float_row(sat, g, y, lanes, d);
    return;
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w && (all_rows || d->rows[y]); ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (!mask[p]) {
        for (int c = 0; c < 3; ++c) d->rgb.at(x, y, c) = 0.f;
        d->use[p] = ViewData::kOff;
        continue;
      }
      ++d->mask_pixels;
      bool ok = g.finite[p] != 0, saturated = false;
      for (int c = 0; c < 3; ++c) {
        const float r = in.at(x, y, in.channels == 3 ? c : 0);
        if (!std::isfinite(r))
          ok = false;
        else if (r >= sat)
          saturated = true;
        const double lin = li.bits ? decode_code(r, s.color) : r;
        if (!std::isfinite(lin) || std::abs(lin) > std::numeric_limits<float>::max()) ok = false;
        d->rgb.at(x, y, c) = static_cast<float>(lin);
      }
      if (!ok) {
        ++d->nonfinite;
        d->use[p] = ViewData::kNonfinite;
        continue;
      }
      if (saturated) {
        ++d->saturated;
        d->use[p] = ViewData::kSaturated;
        continue;
      }
      d->use[p] = ViewData::kUsable;
      ++d->used;
    }
}

}  // namespace

struct GeometryCache::Impl {
  // Not std::call_once: with GCC 12's libstdc++ a callable that throws leaves the flag stuck and
  // the next caller waits forever (GCC bug 66146); a bad buffer must give its message to every
  // view that names it.
  struct Entry {
    std::mutex m;
    std::shared_ptr<const ViewGeometry> geo;  // null until decoded
  };
  std::mutex m;
  std::map<std::string, std::weak_ptr<Entry>> live;
  std::shared_ptr<Entry> latest;  // kept for the views still to come
};

GeometryCache::GeometryCache() : impl_(std::make_unique<Impl>()) {}
GeometryCache::~GeometryCache() = default;

std::shared_ptr<const ViewGeometry> GeometryCache::get(const std::string& key,
                                                       const std::function<ViewGeometry()>& load) {
  std::shared_ptr<Impl::Entry> e;
  {
    std::lock_guard<std::mutex> lock(impl_->m);
    for (auto it = impl_->live.begin(); it != impl_->live.end();)
      it = it->second.expired() ? impl_->live.erase(it) : std::next(it);
    auto it = impl_->live.find(key);
    if (it != impl_->live.end()) e = it->second.lock();
    if (!e) {
      e = std::make_shared<Impl::Entry>();
      impl_->live[key] = e;
    }
    impl_->latest = e;
  }
  // Decoded once, under the entry's lock (a second view naming it waits); a failed decode leaves
  // the entry empty for the next caller to try, and fail with the same message.
  std::lock_guard<std::mutex> lock(e->m);
  if (!e->geo) e->geo = std::make_shared<const ViewGeometry>(load());
  return e->geo;
}

namespace {

// read_geometry_buffers of view i, its errors named by the view.
ViewGeometry read_view_geometry_buffers(const CaptureSet& s, size_t i, const TopologyMap* map,
                                        const std::vector<uint8_t>* only_rows = nullptr,
                                        bool uv_alone = false) {
  try {
    return read_geometry_buffers(s, s.views.at(i), map, only_rows, uv_alone);
  } catch (const Error& e) {
    throw Error(s.file + ": views[" + std::to_string(i) + "].geometry: " + e.what());
  }
}

}  // namespace

std::string geometry_key(const ViewSpec& v) {
  const GeometrySpec& g = v.geometry;
  return g.mesh + '\n' + g.position + '\n' + g.normal + '\n' + g.tangent + '\n' + g.mask + '\n' +
         g.topology + '\n' + g.uv + '\n' + std::to_string(v.camera.width) + 'x' +
         std::to_string(v.camera.height);
}

std::map<std::string, GeometryViews> geometry_views(const CaptureSet& set) {
  std::map<std::string, GeometryViews> out;
  for (size_t i = 0; i < set.views.size(); ++i)
    out.emplace(geometry_key(set.views[i]), GeometryViews{i, 0}).first->second.views += 1;
  return out;
}

std::shared_ptr<const ViewGeometry> load_view_geometry(const CaptureSet& s, size_t i,
                                                       const TopologyMap* map,
                                                       GeometryCache* cache) {
  const ViewSpec& v = s.views.at(i);
  const Intrinsics& k = v.camera;
  const std::string ctx = s.file + ": views[" + std::to_string(i) + "]";
  const GeometrySpec& g = v.geometry;
  if (!g.mesh.empty()) {
    auto geo = std::make_shared<ViewGeometry>();
    geo->mask.assign(static_cast<size_t>(k.width) * k.height, 1);
    try {
      trace_mesh_gbuffer(join_path(s.dir, g.mesh), g.fiber_field, k, v.world_from_camera, &geo->P,
                         &geo->N, &geo->U, &geo->mask);
    } catch (const Error& e) {
      throw Error(ctx + ".geometry.mesh: " + e.what());
    }
    mask_rows(k.width, k.height, geo.get());
    mark_finite(false, geo.get());
    return geo;
  }
  auto load = [&] { return read_view_geometry_buffers(s, i, map); };
  return cache ? cache->get(geometry_key(v), load) : std::make_shared<const ViewGeometry>(load());
}

ViewGeometry load_view_uv(const CaptureSet& s, size_t i) {
  if (!s.views.at(i).geometry.mesh.empty()) throw Error("a traced mesh's uv is not read alone");
  return read_view_geometry_buffers(s, i, nullptr, nullptr, true);
}

std::shared_ptr<const ViewGeometry> load_view_geometry_rows(const CaptureSet& s, size_t i,
                                                            const TopologyMap* map,
                                                            const std::vector<uint8_t>& rows) {
  if (!s.views.at(i).geometry.mesh.empty())
    throw Error("a traced mesh's geometry is not read by rows");
  ViewGeometry g = read_view_geometry_buffers(s, i, map, &rows);
  // Its buffers' allocations go back to the read buffers for the next view's (a band reads every
  // view's: fresh ones were the kernel zeroing pages, most of such a load's time).
  return std::shared_ptr<const ViewGeometry>(new ViewGeometry(std::move(g)),
                                             [](const ViewGeometry* p) {
                                               auto* q = const_cast<ViewGeometry*>(p);
                                               for (Image* im : {&q->P, &q->N, &q->U, &q->uv})
                                                 give_back_to_read_buffers(std::move(*im));
                                               delete p;
                                             });
}

ViewData load_view(const CaptureSet& s, size_t i, const TopologyMap* map, GeometryCache* cache,
                   const ViewRows* rows, bool lanes) {
  ViewData d;
  load_view_into(s, i, &d, map, cache, rows, nullptr, lanes);
  return d;
}

void clear_pixel_states(ViewData* d) {
  const size_t w = d->rows.empty() ? 0 : d->use.size() / d->rows.size();
  for (size_t y = 0; y < d->rows.size(); ++y)
    if (d->rows[y])
      std::fill_n(d->use.begin() + static_cast<std::ptrdiff_t>(y * w), w, ViewData::kOff);
}

void load_view_into(const CaptureSet& s, size_t i, ViewData* into, const TopologyMap* map,
                    GeometryCache* cache, const ViewRows* rows,
                    const std::vector<uint8_t>* geometry_rows, bool lanes) {
  const ViewSpec& v = s.views.at(i);
  const Intrinsics& k = v.camera;
  const std::string ctx = s.file + ": views[" + std::to_string(i) + "]";
  std::vector<uint8_t> use = std::move(into->use);  // its allocation, for this view's
  *into = ViewData{};
  ViewData& d = *into;
  d.use = std::move(use);
  d.eye = v.world_from_camera.translation();
  d.geo = geometry_rows ? load_view_geometry_rows(s, i, map, *geometry_rows)
                        : load_view_geometry(s, i, map, cache);
  // Only the image's rows that hold a sample pixel: every other pixel reads 0 (classify_pixels),
  // and a tilted plate's rows are half of a 2048^2 frame's. Found once per geometry, which a
  // fixed camera's views share. Or the caller's band of them, the others left as they are.
  d.rows = rows ? (*rows)(d.geo) : d.geo->rows;
  if (d.rows.size() != static_cast<size_t>(k.height))
    throw Error(ctx + ": the rows asked for are not the image's");
  LoadedImage li = read_view_image(s, v, ctx, &d.rows, rows == nullptr);
  d.channels = li.image.channels;
  classify_pixels(s, std::move(li), rows == nullptr, lanes, &d);
}

}  // namespace aniso
