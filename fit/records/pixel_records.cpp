// A view's pixels to records (fit/records/pixel_records.h).
#include "fit/records/pixel_records.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "core/frame.h"
#include "fit/records/pixel_frames.h"

namespace aniso::fitting {

size_t usable_on_grid(const ViewData& d, int stride, const UvBand& band) {
  size_t n = 0;
  for (int y = 0; y < d.rgb.height; y += stride)
    for (int x = 0; x < d.rgb.width && d.rows[y]; x += stride) {
      const size_t p = static_cast<size_t>(y) * d.rgb.width + x;
      n += d.usable(p) && (!band.banded || band.keeps(band.texel(d, x, y)));
    }
  return n;
}

namespace {

// Pixel (x, y)'s record (texel t), its V and the `lit` lights already in out->lights from
// out->num_lights on; or, where no light reaches it, counted as unlit (by the band that owns it).
void put_record(const ViewData& d, int x, int y, long t, const LocalDir& V, size_t lit,
                const UvBand& band, RecordSlot* out, FitReport* rep) {
  const size_t p = static_cast<size_t>(y) * d.rgb.width + x;
  const ViewGeometry& g = *d.geo;
  Observation o;
  o.V = V;
  o.first_light = out->light_base + static_cast<uint32_t>(out->num_lights);
  o.num_lights = static_cast<uint32_t>(lit);
  for (int k = 0; k < 3; ++k) o.y[k] = d.rgb.at(x, y, k);
  if (o.num_lights == 0) {
    rep->unlit += band.owns(t);  // no light reaches it: it constrains nothing that is fitted
    return;
  }
  if (out->implausible > 0 &&
      !(std::max({std::abs(o.y[0]), std::abs(o.y[1]), std::abs(o.y[2])}) <= out->implausible)) {
    rep->implausible += band.owns(t);
    return;
  }
  rep->pixels += band.owns(t);
  if (out->uv)
    for (int c = 0; c < 2; ++c) out->uv[2 * out->num_obs + c] = g.uv.px[2 * p + c];
  if (out->texel) out->texel[out->num_obs] = t < 0 ? ObsSet::kNoTexel : static_cast<uint32_t>(t);
  if (out->topo)
    out->topo[2 * out->num_obs] = g.smath_at(p), out->topo[2 * out->num_obs + 1] = g.mapv_at(p);
  out->num_lights += lit;
  out->obs[out->num_obs++] = o;
}

// One pixel in double, one at a time: any lights.
void add_pixel(const ViewData& d, const ViewSpec& v, int x, int y, long t, const UvBand& band,
               RecordSlot* out, FitReport* rep) {
  const ViewGeometry& g = *d.geo;
  SurfacePoint sp;
  if (!frame_at(g.P, g.N, g.U, x, y, &sp)) {
    rep->nonfinite += band.owns(t);
    return;
  }
  size_t lit = 0;
  for (const Light& l : v.lights) {
    Vec3 L;
    RGB E;
    double dist;
    if (!light_at(l, sp.P, &L, &E, &dist)) continue;
    ObsLight ol;
    ol.L = to_local(sp, L);
    if (!(ol.L.n > 0.0)) continue;
    for (int k = 0; k < 3; ++k) ol.E[k] = v.exposure * E[k];
    out->lights[out->num_lights + lit++] = ol;
  }
  put_record(d, x, y, t, to_local(sp, normalize(d.eye - sp.P)), lit, band, out, rep);
}

// Pixel (x, y)'s record (texel t) under v's one point light: its frame (`ok`: the buffers define
// one), V and L in it, the light's attenuation factor f and whether it reaches the point (`lit`),
// as fit/records/pixel_frames.h gives them.
void put_lit(const ViewData& d, const ViewSpec& v, bool ok, const LocalDir& V, const LocalDir& L,
             double f, bool lit, int x, int y, long t, const UvBand& band, RecordSlot* out,
             FitReport* rep) {
  if (!ok) {
    rep->nonfinite += band.owns(t);
    return;
  }
  const Light& light = v.lights[0];
  size_t n_lit = 0;
  const RGB E = {light.intensity[0] * f, light.intensity[1] * f, light.intensity[2] * f};
  if (lit && (E[0] > 0 || E[1] > 0 || E[2] > 0) && L.n > 0.0) {
    ObsLight ol;
    ol.L = L;
    for (int k = 0; k < 3; ++k) ol.E[k] = v.exposure * E[k];
    out->lights[out->num_lights] = ol;
    n_lit = 1;
  }
  put_record(d, x, y, t, V, n_lit, band, out, rep);
}

// The records of up to four pixels (xs[0..n), ys, texels ts) whose quad q holds their frames, V
// and L under v's one point light, in the pixels' order.
void put_quad(const ViewData& d, const ViewSpec& v, const PixelQuad& q, const int* xs,
              const int* ys, const long* ts, int n, const UvBand& band, RecordSlot* out,
              FitReport* rep) {
  for (int l = 0; l < n; ++l)
    put_lit(d, v, q.frame_ok[l], q.V[l], q.L[l], q.f[l], q.lit[l], xs[l], ys[l], ts[l], band, out,
            rep);
}

// The buffers' position, normal and tangent of up to four pixels (xs[0..n), ys) into q's lanes;
// a short quad repeats its last pixel.
void load_quad(const ViewGeometry& g, const int* xs, const int* ys, int n, PixelQuad* q) {
  for (int l = 0; l < 4; ++l) {
    const int x = xs[l < n ? l : n - 1], y = ys[l < n ? l : n - 1];
    for (int c = 0; c < 3; ++c)
      q->P[c][l] = g.P.at(x, y, c), q->N[c][l] = g.N.at(x, y, c), q->U[c][l] = g.U.at(x, y, c);
  }
}

// Up to four pixels (xs[0..n), row y) under one point light, in lanes (fit/records/pixel_frames.h:
// the same bits as add_pixel); the records in the pixels' order.
void add_pixel_quad(const ViewData& d, const ViewSpec& v, int y, const int* xs, const long* ts,
                    int n, const UvBand& band, RecordSlot* out, FitReport* rep) {
  const int ys[4] = {y, y, y, y};
  PixelQuad q;
  load_quad(*d.geo, xs, ys, n, &q);
  pixel_quad(d.eye, v.lights[0], &q);
  put_quad(d, v, q, xs, ys, ts, n, band, out, rep);
}

}  // namespace

void add_pixel_observations(const ViewData& d, const ViewSpec& v, int stride, const UvBand& band,
                            bool simd, RecordSlot* out, FitReport* rep) {
  const int w = d.rgb.width, h = d.rgb.height;
  const bool quads =
      line_lanes_on(simd) && v.lights.size() == 1 && v.lights[0].type == Light::Type::kPoint;
  int xs[4];
  long ts[4];
  for (int y = 0; y < h; y += stride) {
    int n = 0;
    for (int x = 0; x < w && d.rows[y]; x += stride) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (!d.usable(p)) continue;
      const long t = band.w > 0 ? band.texel(d, x, y) : -1;
      if (!band.keeps(t)) continue;
      if (!quads) {
        add_pixel(d, v, x, y, t, band, out, rep);
        continue;
      }
      xs[n] = x, ts[n] = t;
      if (++n == 4) add_pixel_quad(d, v, y, xs, ts, n, band, out, rep), n = 0;
    }
    if (n > 0) add_pixel_quad(d, v, y, xs, ts, n, band, out, rep);
  }
}

bool shares_pixels(size_t views, const ViewSpec& v, const LineLanes& lanes) {
  return views >= kShareFrom && v.geometry.mesh.empty() && v.lights.size() == 1 &&
         v.lights[0].type == Light::Type::kPoint && line_lanes_on(lanes.simd) &&
         lanes.shared_pixels;
}

std::unique_ptr<const SharedPixels> shared_pixels(const ViewData& d, int stride,
                                                  const UvBand& band) {
  const ViewGeometry& g = *d.geo;
  const int w = d.rgb.width, h = d.rgb.height;
  auto sp = std::make_unique<SharedPixels>();
  sp->eye = d.eye;
  for (int y = 0; y < h; y += stride)
    for (int x = 0; x < w && d.rows[y]; x += stride) {
      const size_t p = static_cast<size_t>(y) * w + x;
      if (!g.mask[p] || !g.finite[p]) continue;  // never usable (ViewData::use)
      const long t = band.w > 0 ? band.texel(d, x, y) : -1;
      if (!band.keeps(t)) continue;
      sp->x.push_back(x), sp->y.push_back(y), sp->t.push_back(t);
    }
  const size_t n = sp->x.size();
  sp->padded = (n + kSharedLanes - 1) / kSharedLanes * kSharedLanes;
  sp->frame.resize(SharedPixels::kSharedRows * sp->padded);
  sp->V.resize(n);
  sp->ok.resize(n);
  for (size_t i0 = 0; i0 < n; i0 += 4) {
    PixelQuad q;
    load_quad(g, &sp->x[i0], &sp->y[i0], static_cast<int>(std::min<size_t>(4, n - i0)), &q);
    pixel_frame_quad(d.eye, &q);
    for (size_t l = 0; l < 4 && i0 + l < n; ++l) {
      for (int c = 0; c < 3; ++c) {
        const double at[4] = {q.P[c][l], q.fU[c][l], q.fW[c][l], q.fN[c][l]};
        for (int k = 0; k < 4; ++k) sp->frame[(3 * k + c) * sp->padded + i0 + l] = at[k];
      }
      sp->V[i0 + l] = q.V[l];
      sp->ok[i0 + l] = q.frame_ok[l];
    }
  }
  for (int k = 0; k < SharedPixels::kSharedRows && n > 0; ++k)  // the padding repeats the last
    std::fill(sp->frame.begin() + static_cast<std::ptrdiff_t>(k * sp->padded + n),
              sp->frame.begin() + static_cast<std::ptrdiff_t>((k + 1) * sp->padded),
              sp->frame[k * sp->padded + n - 1]);
  return sp;
}

size_t usable_shared(const ViewData& d, const SharedPixels& sp) {
  const size_t w = static_cast<size_t>(d.rgb.width);
  size_t n = 0;
  for (size_t i = 0; i < sp.x.size(); ++i)
    n += d.usable(static_cast<size_t>(sp.y[i]) * w + static_cast<size_t>(sp.x[i]));
  return n;
}

void add_shared_observations(const ViewData& d, const ViewSpec& v, const SharedPixels& sp,
                             const UvBand& band, bool avx512, RecordSlot* out, FitReport* rep) {
  const size_t w = static_cast<size_t>(d.rgb.width), n = sp.x.size();
  LightLanes ll;
  for (size_t i0 = 0; i0 < n; i0 += kSharedLanes) {
    const size_t m = std::min<size_t>(kSharedLanes, n - i0);
    bool use[kSharedLanes], any = false;
    for (size_t l = 0; l < m; ++l) {
      const size_t i = i0 + l;
      use[l] = d.usable(static_cast<size_t>(sp.y[i]) * w + static_cast<size_t>(sp.x[i]));
      any = any || use[l];
    }
    if (!any) continue;
    shared_light_lanes(v.lights[0], sp.frame.data(), sp.padded, i0, avx512, &ll);
    for (size_t l = 0; l < m; ++l)
      if (use[l]) {
        const size_t i = i0 + l;
        put_lit(d, v, sp.ok[i] != 0, sp.V[i], ll.L[l], ll.f[l], ll.lit[l], sp.x[i], sp.y[i],
                sp.t[i], band, out, rep);
      }
  }
}

}  // namespace aniso::fitting
