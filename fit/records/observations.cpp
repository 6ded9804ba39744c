#include "fit/records/observations.h"

#include <sys/mman.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <mutex>

#include "core/error.h"
#include "core/noise.h"
#include "core/progress.h"
#include "fit/records/load_views.h"
#include "fit/records/pixel_records.h"
#include "fit/records/texel_grid.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"

namespace aniso::fitting {

void add_counts(const FitReport& from, FitReport* to) {
  to->pixels += from.pixels;
  to->masked_out += from.masked_out;
  to->saturated += from.saturated;
  to->nonfinite += from.nonfinite;
  to->unlit += from.unlit;
  to->implausible += from.implausible;
  to->outside_tile += from.outside_tile;
}

void* map_pages(size_t bytes) {
  void* p = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (p == MAP_FAILED) throw std::bad_alloc();
  return p;
}
void unmap_pages(void* p, size_t bytes) { ::munmap(p, bytes); }

namespace {

// The arrays kept beside the records: texture coordinates (--topology-map), texels (--maps), the
// fiber model's topology (a topology buffer or map).
struct Kept {
  bool uv = false, texel = false, topo = false;
};

// f(array, its values per observation) for each array beside the records that `keep` keeps: the
// one place that knows them, for growing, moving, trimming and filtering them with the records.
template <class F>
void for_each_kept(const Kept& keep, ObsSet* os, F f) {
  if (keep.uv) f(os->uv, 2);
  if (keep.texel) f(os->texel, 1);
  if (keep.topo) f(os->topo, 2);
}

// Values far above anything else in the set (hot pixels, a broken writer's 1e30) would steer the
// closed-form start and the noise estimate before any robust loss can act: a pixel with a value
// above kImplausible times the 90th percentile of all values is left out and counted (a real
// highlight is brighter than most pixels, but not 10^4 times brighter than the brightest tenth).
// `given` > 0: that limit instead (a --global fit's, for the maps after it).
void drop_implausible(const Kept& keep, ObsSet* os, FitReport* rep, double given) {
  double limit = given;
  if (!(limit > 0)) {
    if (os->obs.size() < 100) return;
    // From at most kSample pixels, evenly strided (a copy of every value was a tenth of the
    // records, at the peak): the 90th percentile of 16384 values is within ~0.3 % of its rank.
    constexpr size_t kSample = 16384;
    const size_t stride = (os->obs.size() + kSample - 1) / kSample;
    std::vector<float> mags;
    mags.reserve(os->obs.size() / stride + 1);
    for (size_t i = 0; i < os->obs.size(); i += stride) {
      const Observation& o = os->obs[i];
      mags.push_back(std::max({std::abs(o.y[0]), std::abs(o.y[1]), std::abs(o.y[2])}));
    }
    std::nth_element(mags.begin(), mags.begin() + mags.size() * 9 / 10, mags.end());
    const double p90 = mags[mags.size() * 9 / 10];
    constexpr double kImplausible = 1e4;
    limit = kImplausible * std::max(p90, 1e-12);
  }
  rep->implausible_limit = limit;
  size_t kept = 0;
  for (size_t i = 0; i < os->obs.size(); ++i) {
    const Observation& o = os->obs[i];
    if (!(std::max({std::abs(o.y[0]), std::abs(o.y[1]), std::abs(o.y[2])}) <= limit)) {
      ++rep->implausible;
      continue;
    }
    for_each_kept(keep, os, [&](auto& v, size_t per) {
      std::copy_n(v.begin() + per * i, per, v.begin() + per * kept);
    });
    os->obs[kept++] = o;
  }
  os->obs.resize(kept);
  for_each_kept(keep, os, [&](auto& v, size_t per) { v.resize(per * kept); });
}

}  // namespace

void choose_topology(const CaptureSet& set, const FitOptions& opt, ObsSet* os) {
  const bool has_map = !set.topology_map.empty();
  if (has_map) {
    os->topology = TopologyMode::kAmplitude;
    os->topology_map = join_path(set.dir, set.topology_map);  // made relative on writing
  }
  bool has_buffer = false;
  for (const auto& v : set.views) has_buffer |= !v.geometry.topology.empty();
  if (has_buffer) {
    // The kind of mathematical topology, when the writer recorded it (capture_sim does); "torus"
    // otherwise (docs/formats.md's name for a per-pixel mathematical topology).
    os->topology_mathematical = MathTopology::kTorus;
    if (!set.provenance.empty()) {
      const auto g = jsonu::json::parse(set.provenance, nullptr, false);
      if (g.is_object() && g.contains("mathematical_topology") &&
          g["mathematical_topology"] == "sphere")
        os->topology_mathematical = MathTopology::kSphere;
    }
  }
  if (has_buffer && !has_map) os->topology = TopologyMode::kMathematical;
  if (opt.topology_texels <= 0) return;
  if (opt.topology_texels < 2 || opt.topology_texels > 256)
    throw Error("fit: --topology-map N needs N in [2, 256]");
  if (has_map || has_buffer)
    throw Error(set.file +
                ": --topology-map fits s per texel, but this set has a topology map or buffer (its "
                "amplitude is what can be fitted: leave --topology-map out)");
  for (const auto& v : set.views)
    if (v.geometry.uv.empty())
      throw Error(set.file + ": --topology-map needs the \"uv\" buffer in every view's geometry");
  os->topology = TopologyMode::kTexels;
  os->texels = opt.topology_texels;
}

namespace {

// The rows the noise estimate takes (add_neighbour_differences): every step-th.
int noise_row_step(size_t views, int w, int h) {
  constexpr double kMostNoiseDifferences = 1 << 22;
  const double all_rows = 3.0 * views * w * h;
  return std::max(4, static_cast<int>(std::ceil(all_rows / kMostNoiseDifferences)));
}

// Without bands, subsampled: the rows of geometry g (key `key`) with a mask pixel on the stride
// grid's rows or the noise estimate's, found once per geometry.
const std::vector<uint8_t>& grid_rows_of(LoadState* st, const std::string& key,
                                         const ViewGeometry& g, int stride, int noise_step) {
  std::lock_guard<std::mutex> lock(st->geo_mutex);
  auto& rows = st->grid_rows[key];
  if (!rows) {
    rows = std::make_unique<std::vector<uint8_t>>(g.rows);
    for (size_t y = 0; y < rows->size(); ++y)
      (*rows)[y] = (*rows)[y] && (y % stride == 0 || y % noise_step == 0);
  }
  return *rows;
}

// Second differences of three horizontal neighbours (a - 2b + c cancels the shading's gradient)
// on every 4th row, or sparser rows where a set of `views` such views would give more than
// kMostNoiseDifferences: enough for a median (its relative spread ~1 / sqrt(count)), little time
// and memory (every 4th row of 64 views of 2048^2 was ~90 million values, 360 MB at the load's
// peak, and a serial median). Zeros are clipped values.
// With `first` (bands), only the rows band `band` is the first to read.
void add_neighbour_differences(const ViewData& d, size_t views, const std::vector<int>* first,
                               int band, std::vector<float>* diffs) {
  const int step = noise_row_step(views, d.rgb.width, d.rgb.height);
  for (int y = 0; y < d.rgb.height; y += step)
    for (int x = 0; x + 2 < d.rgb.width && (!first || (*first)[y] == band); ++x) {
      const size_t p = static_cast<size_t>(y) * d.rgb.width + x;
      if (d.usable(p) && d.usable(p + 1) && d.usable(p + 2))
        for (int c = 0; c < d.channels; ++c) {
          const float a = d.rgb.px[3 * p + c], b = d.rgb.px[3 * (p + 1) + c],
                      e = d.rgb.px[3 * (p + 2) + c];
          if (a > 0 && b > 0 && e > 0) diffs->push_back(a - 2 * b + e);
        }
    }
}

// One view of a batch: its decoded data until its records are written, and what it reports.
struct ViewPart {
  ViewData d;
  FitReport rep;
  std::vector<float> diffs;
  size_t bound = 0;  // usable pixels on the stride grid
  RecordSlot slot{nullptr, nullptr, 0};
  const SharedPixels* shared = nullptr;  // the pixels it shares with views of its geometry
};

// The pixels view d (of geometry `key`, which `views` views name) shares with the others of its
// geometry and eye in this load, found by the first to ask; null where there is nothing to share
// (shares_pixels: its geometry its own or shared by fewer than kShareFrom views, or other than
// one point light: add_pixel_observations' own cases) or its eye is not theirs.
const SharedPixels* shared_of(LoadState* st, const std::string& key, size_t views,
                              const ViewData& d, const ViewSpec& v, int stride, const UvBand& band,
                              const LineLanes& lanes) {
  if (!shares_pixels(views, v, lanes)) return nullptr;
  std::lock_guard<std::mutex> lock(st->shared_mutex);
  auto it = st->shared.find(key);
  if (it == st->shared.end()) {
    it = st->shared.emplace(key, shared_pixels(d, stride, band)).first;
    if (it->second) st->shared_bytes += it->second->bytes();
  }
  const SharedPixels* sp = it->second.get();
  return sp && sp->eye.x == d.eye.x && sp->eye.y == d.eye.y && sp->eye.z == d.eye.z ? sp : nullptr;
}

// Grows an array by `more` unwritten records; before the first batch, room for as many again for
// every batch still to come (one allocation where every view sees the sample alike).
template <class V>
size_t grow_by(V* v, size_t more, size_t batches_left) {
  const size_t at = v->size();
  if (v->capacity() < at + more)
    v->reserve(std::max(at + more * batches_left, v->capacity() + v->capacity() / 2));
  v->resize(at + more);
  return at;
}

// Closes the gaps a batch's views left in their slots (pixels without a frame or a light) and
// trims the arrays to what was written; the reports are added up in view order.
void close_gaps(std::vector<ViewPart>* parts, size_t obs_start, size_t light_start, Kept keep,
                ObsSet* os, FitReport* rep, std::vector<float>* diffs) {
  size_t o_end = obs_start, l_end = light_start;
  for (ViewPart& p : *parts) {
    const size_t o_at = static_cast<size_t>(p.slot.obs - os->obs.data());
    const size_t l_at = p.slot.light_base;
    if (l_at != l_end) {
      const auto shift = static_cast<uint32_t>(l_at - l_end);
      std::memmove(os->lights.data() + l_end, os->lights.data() + l_at,
                   p.slot.num_lights * sizeof(ObsLight));
      for (size_t j = 0; j < p.slot.num_obs; ++j) p.slot.obs[j].first_light -= shift;
    }
    if (o_at != o_end) {
      std::memmove(os->obs.data() + o_end, p.slot.obs, p.slot.num_obs * sizeof(Observation));
      for_each_kept(keep, os, [&](auto& v, size_t per) {
        std::memmove(v.data() + per * o_end, v.data() + per * o_at,
                     per * p.slot.num_obs * sizeof(v[0]));
      });
    }
    os->view_lights.push_back(l_end);
    o_end += p.slot.num_obs;
    l_end += p.slot.num_lights;
    diffs->insert(diffs->end(), p.diffs.begin(), p.diffs.end());
    add_counts(p.rep, rep);
    p = ViewPart{};
  }
  os->obs.resize(o_end);
  os->lights.resize(l_end);
  for_each_kept(keep, os, [&](auto& v, size_t per) { v.resize(per * o_end); });
}

// Room in the set's arrays for a batch of views from view b0 on (each view's usable pixels and as
// many lights each), and each view's slot in it; *obs_start, *light_start: where the batch begins.
void make_room(const CaptureSet& set, size_t b0, size_t batches_left, Kept keep, double implausible,
               std::vector<ViewPart>* parts, ObsSet* os, size_t* obs_start, size_t* light_start) {
  size_t more_obs = 0, more_lights = 0;
  for (size_t k = 0; k < parts->size(); ++k) {
    more_obs += (*parts)[k].bound;
    more_lights += (*parts)[k].bound * set.views[b0 + k].lights.size();
  }
  *obs_start = grow_by(&os->obs, more_obs, batches_left);
  *light_start = grow_by(&os->lights, more_lights, batches_left);
  for_each_kept(keep, os, [&](auto& v, size_t per) { grow_by(&v, per * more_obs, batches_left); });
  if (os->lights.size() > std::numeric_limits<uint32_t>::max())
    throw Error(set.file + ": more than 2^32 pixel lights; fit with --subsample");
  size_t o_at = *obs_start, l_at = *light_start;
  for (size_t k = 0; k < parts->size(); ++k) {
    ViewPart& p = (*parts)[k];
    p.slot = RecordSlot{os->obs.data() + o_at,
                        os->lights.data() + l_at,
                        static_cast<uint32_t>(l_at),
                        keep.uv ? os->uv.data() + 2 * o_at : nullptr,
                        keep.texel ? os->texel.data() + o_at : nullptr,
                        keep.topo ? os->topo.data() + 2 * o_at : nullptr};
    p.slot.implausible = implausible;
    o_at += p.bound;
    l_at += p.bound * set.views[b0 + k].lights.size();
  }
}

}  // namespace

double pixel_noise(std::vector<float>* diffs) { return second_difference_noise(diffs); }

void load_views(const CaptureSet& set, const FitOptions& opt, LoadState* st, ObsSet* os_out,
                FitReport* rep_out) {
  if (opt.subsample < 1) throw Error("fit: --subsample must be at least 1");
  ObsSet& os = *os_out;
  os.obs.clear(), os.lights.clear(), os.uv.clear(), os.texel.clear(), os.topo.clear();
  os.view_lights.clear();
  FitReport& rep = *rep_out;
  rep.views = set.views.size();
  if (!set.provenance.empty()) {
    const auto g = jsonu::json::parse(set.provenance, nullptr, false);
    os.from_shoot = g.is_object() && g.value("tool", "") == "aniso import";
    const double assumed = os.from_shoot && g.contains("paper_reflectance_assumed") &&
                                   g["paper_reflectance_assumed"].is_number()
                               ? g["paper_reflectance_assumed"].get<double>()
                               : 0;
    if (assumed > 0 && st->band == 0) {
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "k_d and k_s are relative, not absolute: the lamps' intensities came from the "
                    "board's paper taken as reflecting %.2f; lay a grey card on the board (the "
                    "shoot's reference) or give board.paper_reflectance, and import again to "
                    "make them absolute",
                    assumed);
      rep.warnings.push_back(buf);
    }
  }
  choose_topology(set, opt, &os);
  if (opt.maps_w > 0)
    for (size_t i = 0; i < set.views.size(); ++i) {
      if (set.views[i].geometry.uv.empty())
        throw Error(set.file + ": views[" + std::to_string(i) +
                    "]: --maps needs texture "
                    "coordinates: a \"uv\" buffer in every view's geometry");
      // A mesh is traced for position, normal and tangent alone: its uv buffer would not be read.
      if (!set.views[i].geometry.mesh.empty())
        throw Error(set.file + ": views[" + std::to_string(i) +
                    "].geometry: --maps reads texture coordinates from the \"uv\" buffer beside "
                    "the position, normal and tangent buffers; a \"mesh\" view's are not traced "
                    "(write its buffers, as capture_sim does)");
    }
  if (os.topology == TopologyMode::kAmplitude && !st->map_loaded)
    st->map = load_topology_map(os.topology_map), st->map_loaded = true;
  const bool banded = !st->bands.empty();
  UvBand band;
  if (banded) band = st->bands.at(st->band);
  band.w = opt.maps_w, band.h = opt.maps_h;
  std::string what = "fit: loading views";
  if (st->bands.size() > 1)
    what = "fit: band " + std::to_string(st->band + 1) + "/" + std::to_string(st->bands.size()) +
           ": loading views";
  Progress bar(what, set.views.size(), opt.progress);
  std::atomic<size_t> grey_views{0};
  // Views are decoded a few at a time on the solver's threads; then the batch's room is made in
  // the set's arrays and each view's thread writes its records in place (no copy, and the new
  // pages are touched on both cores), the gaps closed in view order.
  const size_t batch = 2 * static_cast<size_t>(std::max(1, opt.threads)), n = set.views.size();
  tbb::task_arena arena(std::max(1, opt.threads));
  const TopologyMap* tmap = os.topology == TopologyMode::kAmplitude ? &st->map : nullptr;
  // A band reads the rows with a pixel it keeps; the noise takes each row once, from the first
  // band to read it (the same differences as one load of every row). A view whose geometry no
  // other view shares reads, after the first band, only those rows of its geometry too.
  if (st->geometries.empty()) st->geometries = geometry_views(set);
  st->shared_bytes = 0;
  // Both checked for uv above.
  const Kept keep{
      opt.topology_texels > 0, opt.maps_w > 0,
      os.topology == TopologyMode::kAmplitude || os.topology == TopologyMode::kMathematical};
  try {  // bands: room for every band at once (BandLoader::record_bytes; 0 otherwise)
    os.obs.reserve(st->reserve_obs);
    os.lights.reserve(st->reserve_lights);
    for_each_kept(keep, &os, [&](auto& v, size_t per) { v.reserve(per * st->reserve_obs); });
  } catch (const std::bad_alloc&) {  // the arrays grow as they are written instead
  }
  const double given = opt.global ? opt.global->implausible_limit : 0;
  const size_t pixels_before = rep.pixels;
  for (size_t b0 = 0; b0 < n; b0 += batch) {
    const size_t b1 = std::min(n, b0 + batch);
    std::vector<ViewPart> parts(b1 - b0);
    arena.execute([&] {
      tbb::parallel_for(b0, b1, [&](size_t i) {
        ViewPart& p = parts[i - b0];
        {
          std::lock_guard<std::mutex> lock(st->use_mutex);
          if (!st->spare_use.empty())
            p.d.use = std::move(st->spare_use.back()), st->spare_use.pop_back();
        }
        const std::string key = geometry_key(set.views[i]);
        const ViewRows rows =
            [&](const std::shared_ptr<const ViewGeometry>& g) -> const std::vector<uint8_t>& {
          return rows_of(st, key, g.get(), opt.subsample)->rows[st->band];
        };
        const LoadState::GeoRows* known = banded && st->band > 0 &&
                                                  set.views[i].geometry.mesh.empty() &&
                                                  st->geometries.at(key).views == 1
                                              ? rows_of(st, key, nullptr, opt.subsample)
                                              : nullptr;
        // Subsampled without bands: only the rows of the grid and of the noise estimate.
        const ViewRows grid =
            [&](const std::shared_ptr<const ViewGeometry>& g) -> const std::vector<uint8_t>& {
          const Intrinsics& k = set.views[i].camera;
          return grid_rows_of(st, key, *g, opt.subsample, noise_row_step(n, k.width, k.height));
        };
        const bool on_grid = !banded && opt.subsample > 1 && set.views[i].geometry.mesh.empty();
        load_view_into(set, i, &p.d, tmap, &st->geometry,
                       banded    ? &rows
                       : on_grid ? &grid
                                 : nullptr,
                       known ? &known->rows[st->band] : nullptr);
        grey_views += p.d.channels == 1;
        const size_t pixels = static_cast<size_t>(p.d.rgb.width) * p.d.rgb.height;
        if (!banded) {
          add_neighbour_differences(p.d, n, nullptr, 0, &p.diffs);
          p.rep.masked_out = pixels - p.d.geo->mask_count;
          count_left_out(p.d, band, opt.subsample, &p.rep);
        } else {
          const LoadState::GeoRows& r = *rows_of(st, key, p.d.geo.get(), opt.subsample);
          add_neighbour_differences(p.d, n, &r.first, static_cast<int>(st->band), &p.diffs);
          if (band.first)
            p.rep.masked_out = pixels - p.d.geo->mask_count, p.rep.outside_tile = r.outside;
          count_left_out(p.d, band, opt.subsample, &p.rep);
        }
        p.shared = set.views[i].geometry.mesh.empty()
                       ? shared_of(st, key, st->geometries.at(key).views, p.d, set.views[i],
                                   opt.subsample, band, opt.line_lanes)
                       : nullptr;
        p.bound =
            p.shared ? usable_shared(p.d, *p.shared) : usable_on_grid(p.d, opt.subsample, band);
      });
    });
    size_t obs_start, light_start;
    make_room(set, b0, (n - b0 + batch - 1) / batch, keep, banded ? given : 0, &parts, &os,
              &obs_start, &light_start);
    arena.execute([&] {
      tbb::parallel_for(b0, b1, [&](size_t i) {
        ViewPart& p = parts[i - b0];
        if (p.shared)
          add_shared_observations(p.d, set.views[i], *p.shared, band, opt.line_lanes.avx512,
                                  &p.slot, &p.rep);
        else
          add_pixel_observations(p.d, set.views[i], opt.subsample, band, opt.line_lanes.simd,
                                 &p.slot, &p.rep);
        st->read_buffers->give_back(std::move(p.d.rgb));
        {
          clear_pixel_states(&p.d);
          std::lock_guard<std::mutex> lock(st->use_mutex);
          st->spare_use.push_back(std::move(p.d.use));
        }
        p.d = ViewData{};
        bar.advance();
      });
    });
    close_gaps(&parts, obs_start, light_start, keep, &os, &rep, &st->diffs);
  }
  st->shared.clear();
  // The implausible values and the noise estimate are independent: side by side. Bands left the
  // implausible values out as they wrote the records (a --global fit's limit), and their noise
  // waits for the last band's rows.
  if (banded) {
    rep.implausible_limit = given;
  } else {
    tbb::parallel_invoke([&] { drop_implausible(keep, &os, &rep, given); },
                         [&] { os.pixel_noise = pixel_noise(&st->diffs); });
  }
  // Grey images: the three channels repeat one measurement, counted once (as for grey tables).
  os.grey = grey_views == set.views.size();
  os.simd = opt.line_lanes.simd;
  // A band counts the pixels of the texels it owns (its reach's are the next band's), as it
  // writes them.
  const size_t pixels = banded ? rep.pixels - pixels_before : os.obs.size();
  rep.pixels = pixels_before + pixels;
  rep.observations += pixels * (os.grey ? 1 : 3);
  if (band.first && (set.ambient[0] != 0 || set.ambient[1] != 0 || set.ambient[2] != 0))
    rep.warnings.push_back(
        set.file + ": its ambient " + jsonu::to_json(set.ambient).dump() +
        " is not fitted: k_a is taken as 0 and the values as the lights' sum alone (a sample that "
        "reflects the ambient light shows it as a higher k_d)");
}

size_t held_bytes(const ObsSet& os) {
  return os.obs.size() * sizeof(Observation) + os.lights.size() * sizeof(ObsLight) +
         (os.uv.size() + os.topo.size()) * sizeof(float) + os.texel.size() * sizeof(uint32_t);
}

ObsSet capture_observations(const CaptureSet& set, const FitOptions& opt, FitReport* rep) {
  LoadState st;
  ObsSet os;
  load_views(set, opt, &st, &os, rep);
  return os;
}

ObsSet table_observations(const SampleTable& t, const FitOptions& opt, FitReport* rep) {
  if (t.values == SampleTable::Values::kNone)
    throw Error("fit: the sample table has no value columns (r,g,b or y)");
  ObsSet os;
  os.grey = t.values == SampleTable::Values::kGrey;
  os.simd = opt.line_lanes.simd;
  for (const auto& row : t.rows) {
    Observation o;
    o.V = dir_from_angles(row.theta_o, row.phi_o);
    ObsLight l;
    l.L = dir_from_angles(row.theta_i, row.phi_i);
    l.E[0] = l.E[1] = l.E[2] = 1.0;
    for (int k = 0; k < 3; ++k) o.y[k] = row.value[k];
    if (!(l.L.n > 0.0)) {
      ++rep->unlit;
      continue;
    }
    o.first_light = static_cast<uint32_t>(os.lights.size());
    o.num_lights = 1;
    os.lights.push_back(l);
    os.obs.push_back(o);
    if (t.has_s) os.topo.insert(os.topo.end(), {static_cast<float>(row.s), 0.f});
    if (t.has_uv && opt.maps_w > 0) {  // --maps: the spot's texel
      const long tx = texel_of(row.u, row.v, opt.maps_w, opt.maps_h);
      os.texel.push_back(tx < 0 ? ObsSet::kNoTexel : static_cast<uint32_t>(tx));
    }
  }
  // A table with an s column gives the fiber model's topology per row; otherwise one s is fitted.
  if (t.has_s) os.topology = TopologyMode::kMathematical;
  rep->pixels = os.obs.size();
  rep->observations = os.obs.size() * (os.grey ? 1 : 3);
  return os;
}

std::vector<size_t> start_subset(size_t n, size_t count) {
  std::vector<size_t> idx;
  if (n <= count) {
    idx.resize(n);
    for (size_t i = 0; i < n; ++i) idx[i] = i;
    return idx;
  }
  constexpr double kGolden = 0.6180339887498949;
  std::vector<uint8_t> taken(n, 0);
  double x = 0.5;
  for (size_t k = 0; k < count; ++k) {
    x += kGolden;
    x -= std::floor(x);
    const size_t i = std::min(n - 1, static_cast<size_t>(x * static_cast<double>(n)));
    if (!taken[i]) {
      taken[i] = 1;
      idx.push_back(i);
    }
  }
  std::sort(idx.begin(), idx.end());
  return idx;
}

double median_abs(std::vector<double> v) {
  if (v.empty()) return 0;
  for (double& x : v) x = std::abs(x);
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace aniso::fitting
