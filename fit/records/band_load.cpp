// A capture's observations band by band of the maps' texel rows (fit/records/band_load.h): which
// rows of a geometry each band reads, the counts a band owns, and the loader that keeps its state
// from band to band.
#include "fit/records/band_load.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <map>
#include <string>
#include <utility>

#include "core/error.h"
#include "fit/records/load_views.h"

namespace aniso::fitting {

namespace {

// The rows every band reads of geometry g: the rows holding a mask pixel whose texel it keeps.
// One pass over the pixels, each texel row's bands (an interval: a band's rows and its reach)
// looked up.
std::unique_ptr<LoadState::GeoRows> band_rows(const ViewGeometry& g,
                                              const std::vector<UvBand>& bands, int stride) {
  const UvBand& b0 = bands.front();
  const int W = g.P.width, H = g.P.height;
  auto r = std::make_unique<LoadState::GeoRows>();
  r->rows.assign(bands.size(), std::vector<uint8_t>(static_cast<size_t>(H), 0));
  r->first.assign(static_cast<size_t>(H), -1);
  std::vector<std::pair<int, int>> of_row(static_cast<size_t>(b0.h), {1, 0});  // [lo, hi]
  for (size_t j = 0; j < bands.size(); ++j)
    for (long t = bands[j].k0; t < bands[j].k1; t += b0.w) {
      auto& [lo, hi] = of_row[static_cast<size_t>(t / b0.w)];
      if (lo > hi) lo = static_cast<int>(j);
      hi = static_cast<int>(j);
    }
  for (int y = 0; y < H; ++y) {
    bool no_texel = false;  // a pixel whose uv is outside [0, 1)^2: the first band's
    for (int x = 0; x < W; ++x) {
      const size_t p = static_cast<size_t>(y) * W + x;
      if (!g.mask[p]) continue;
      const long t = texel_of(g.uv.px[2 * p], g.uv.px[2 * p + 1], b0.w, b0.h);
      // Another tile's pixel (its rows', counted there; its reach's are read, not counted).
      if (b0.tile && !(t >= b0.tile_o0 && t < b0.tile_o1))
        r->outside += g.finite[p] && x % stride == 0 && y % stride == 0;
      if (t < 0) {  // read for its counts by the first band (of the first tile)
        no_texel |= b0.first_tile;
        continue;
      }
      if (!b0.in_tile(t)) continue;
      const auto [a, b] = of_row[static_cast<size_t>(t / b0.w)];
      for (int j = a; j <= b; ++j) r->rows[j][y] = 1;  // the bands keeping texel row t / w
    }
    if (no_texel) r->rows[0][y] = 1;
    for (size_t j = 0; j < bands.size() && r->first[y] < 0; ++j)
      if (r->rows[j][y]) r->first[y] = static_cast<int>(j);
  }
  return r;
}

}  // namespace

const LoadState::GeoRows* rows_of(LoadState* st, const std::string& key, const ViewGeometry* geo,
                                  int stride) {
  std::lock_guard<std::mutex> lock(st->geo_mutex);
  auto it = st->geo_rows.find(key);
  if (it != st->geo_rows.end()) return it->second.get();
  if (!geo) return nullptr;
  return (st->geo_rows[key] = band_rows(*geo, st->bands, stride)).get();
}

void count_left_out(const ViewData& d, const UvBand& band, int stride, FitReport* rep) {
  // What it counts is a part of what the view's load counted in the same rows: none there, none
  // here (most views: no pass over their pixels).
  if (d.saturated == 0 && d.nonfinite == 0) return;
  const int w = d.rgb.width;
  for (int y = 0; y < d.rgb.height; y += stride)
    for (int x = 0; x < w && d.rows[y]; x += stride) {
      const size_t p = static_cast<size_t>(y) * w + x;
      const uint8_t u = d.use[p];
      if (u != ViewData::kSaturated && u != ViewData::kNonfinite) continue;
      if (band.banded && !band.owns(band.texel(d, x, y))) continue;
      (u == ViewData::kSaturated ? rep->saturated : rep->nonfinite) += 1;
    }
}

struct BandLoader::Impl {
  const CaptureSet& set;
  FitOptions opt;
  LoadState st;
  ObsSet os;
  // record_bytes' view 0 geometry and bytes a pixel, for row_bytes (counted when first asked).
  std::shared_ptr<const ViewGeometry> g0;
  size_t per = 0;
  bool counted = false;
  std::vector<double> row_bytes, shared_row_bytes;
};

BandLoader::BandLoader(const CaptureSet& set, const FitOptions& opt)
    : impl_(new Impl{set, opt, {}, {}, {}, 0, false, {}, {}}) {}

namespace {

// The mask pixels of g on the grid of `stride` by texel row of a w x h map (outside: row 0).
std::vector<double> pixels_by_row(const ViewGeometry& g, int stride, int w, int h) {
  std::vector<double> n(static_cast<size_t>(std::max(h, 1)), 0.0);
  const int H = static_cast<int>(g.rows.size());
  const int W = H > 0 ? static_cast<int>(g.mask.size() / g.rows.size()) : 0;
  for (int y = 0; y < H; y += stride)
    for (int x = 0; x < W && g.rows[y]; x += stride) {
      const size_t p = static_cast<size_t>(y) * W + x;
      if (!g.mask[p]) continue;
      const long t = g.uv.empty() ? -1 : texel_of(g.uv.px[2 * p], g.uv.px[2 * p + 1], w, h);
      n[t < 0 ? 0 : static_cast<size_t>(t / w)] += 1;
    }
  return n;
}

// The bytes a load holds by texel row: every view's pixels on the grid by texel row times `per`,
// and the pixels views of one geometry share (kSharedPixelBytes each), from view 0's geometry g0
// where every view shares it (a fixed camera); where views have geometry of their own (an orbit),
// each spreads its pixels over the rows its own way, and each geometry's mask and uv are read
// once more (one at a time on each thread; its position, normal and tangent, three times the
// bytes, are not): by view 0's alone, the 32-view 512^2 orbit set's largest band at
// --maps-memory 20 held 23.7 MB.
// *shared: of those, the shared pixels' by row.
std::vector<double> bytes_by_row_all(const CaptureSet& set, const FitOptions& opt,
                                     const ViewGeometry& g0, size_t per,
                                     std::vector<double>* shared) {
  std::vector<GeometryViews> todo;
  for (const auto& [key, g] : geometry_views(set)) todo.push_back(g);
  std::vector<std::vector<double>> counts(todo.size());
  tbb::parallel_for(size_t{0}, todo.size(), [&](size_t j) {
    const size_t i = todo[j].first;
    if (i == 0) {
      counts[j] = pixels_by_row(g0, opt.subsample, opt.maps_w, opt.maps_h);
      return;
    }
    counts[j] = pixels_by_row(load_view_uv(set, i), opt.subsample, opt.maps_w, opt.maps_h);
  });
  std::vector<double> sum(static_cast<size_t>(std::max(opt.maps_h, 1)), 0.0);
  shared->assign(sum.size(), 0.0);
  for (size_t j = 0; j < todo.size(); ++j) {
    const size_t views = todo[j].views;
    const double own = shares_pixels(views, set.views[todo[j].first], opt.line_lanes)
                           ? static_cast<double>(kSharedPixelBytes)
                           : 0.0;
    const double each = static_cast<double>(views * per) + own;
    for (size_t r = 0; r < sum.size(); ++r)
      sum[r] += each * counts[j][r], (*shared)[r] += own * counts[j][r];
  }
  return sum;
}

}  // namespace

size_t BandLoader::record_bytes(bool estimate_only) {
  const CaptureSet& set = impl_->set;
  const FitOptions& opt = impl_->opt;
  LoadState& st = impl_->st;
  if (set.views.empty()) return 0;
  ObsSet os;
  choose_topology(set, opt, &os);
  if (os.topology == TopologyMode::kAmplitude && !st.map_loaded)
    st.map = load_topology_map(os.topology_map), st.map_loaded = true;
  const ViewSpec& v = set.views[0];
  size_t pixels = static_cast<size_t>(v.camera.width) * v.camera.height;
  impl_->g0.reset();
  impl_->counted = false;
  if (v.geometry.mesh.empty()) {  // a mesh is traced per view: the frame's pixels, not its mask
    impl_->g0 = estimate_only
                    ? std::make_shared<const ViewGeometry>(load_view_uv(set, 0))
                    : load_view_geometry(
                          set, 0, os.topology == TopologyMode::kAmplitude ? &st.map : nullptr,
                          &st.geometry);
    pixels = impl_->g0->mask_count;
  }
  const size_t per =
      sizeof(Observation) + v.lights.size() * sizeof(ObsLight) + sizeof(uint32_t) +
      (opt.topology_texels > 0 ? 2 * sizeof(float) : 0) +
      (os.topology == TopologyMode::kAmplitude || os.topology == TopologyMode::kMathematical
           ? 2 * sizeof(float)
           : 0);
  const size_t s2 = static_cast<size_t>(opt.subsample) * opt.subsample;
  const size_t each = pixels / std::max<size_t>(1, s2);
  st.reserve_obs = set.views.size() * each;
  st.reserve_lights = 0;
  for (const ViewSpec& view : set.views) st.reserve_lights += view.lights.size() * each;
  impl_->per = per;
  return st.reserve_obs * per;
}

size_t BandLoader::record_pixels() const { return impl_->st.reserve_obs; }

const std::vector<double>& BandLoader::row_bytes() {
  Impl& m = *impl_;
  if (m.counted) return m.row_bytes;
  m.counted = true;
  m.row_bytes.clear();
  m.shared_row_bytes.clear();
  bool meshes = false;  // a traced mesh's rows are not known before it is traced
  for (const ViewSpec& view : m.set.views) meshes = meshes || !view.geometry.mesh.empty();
  if (!m.g0 || meshes || m.opt.maps_w <= 0) return m.row_bytes;
  m.row_bytes = bytes_by_row_all(m.set, m.opt, *m.g0, m.per, &m.shared_row_bytes);
  return m.row_bytes;
}

const std::vector<double>& BandLoader::shared_row_bytes() {
  row_bytes();
  return impl_->shared_row_bytes;
}

void BandLoader::plan(std::vector<UvBand> bands) {
  if (bands.empty()) throw Error("fit: no bands to load");
  impl_->st.bands = std::move(bands);
}

BandLoader::~BandLoader() = default;

const ObsSet& BandLoader::load(size_t j, FitReport* rep) {
  if (j >= impl_->st.bands.size()) throw Error("fit: no band " + std::to_string(j));
  impl_->st.band = j;
  load_views(impl_->set, impl_->opt, &impl_->st, &impl_->os, rep);
  return impl_->os;
}

const ObsSet& BandLoader::observations() const { return impl_->os; }

size_t BandLoader::held_bytes() const {
  return fitting::held_bytes(impl_->os) + impl_->st.shared_bytes;
}

size_t BandLoader::shared_bytes() const { return impl_->st.shared_bytes; }

double BandLoader::pixel_noise() { return fitting::pixel_noise(&impl_->st.diffs); }

}  // namespace aniso::fitting
