// --maps: per-texel maps of the line model and the fiber model. The observations are
// binned by the texel their texture coordinates fall in; each texel is its own small problem
// (fit/maps/texel_solve.h: k_d, k_s, log n, psi, and the fiber model's s), optionally pulled toward
// its neighbours by Jacobi sweeps (--smooth). A texel whose data do not determine it keeps the
// global values, marked, with the prior's spread as its sigma: never a confident number it did
// not earn.
#include "fit/maps/maps.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <type_traits>
#include <utility>

#include "core/angles.h"
#include "core/progress.h"
#include "fit/maps/texel_sigmas.h"
#include "fit/maps/texel_solve.h"
#include "fit/solvers/line_solve.h"
#include "fit/solvers/texel_lanes.h"
#include "models/params.h"

namespace aniso::fitting {

namespace {

constexpr size_t kMinTexelPixels = 12;  // fewer: not even tried

// Per texel, left unwritten when sized (RecordAllocator): the solving threads write each entry.
static_assert(std::is_trivially_copyable_v<TexelResult>, "written over unconstructed entries");
using TexelResults = std::vector<TexelResult, RecordAllocator<TexelResult>>;

double prior_sigma(const char* key) { return line_param(key).spread(); }

// values (`global`, `s`) with the prior's spread as sigma.
void put_texel(const TexelResult& res, size_t t, const Core& global, double s, const char* s_param,
               TexelMaps* m) {
  m->determined[t] = res.determined;
  // Without a lobe (texel_sigmas' NoLobe hold) the data do not move n, nor the fiber model's k_s:
  // their sigma is past every spread, and their value is written as the global's n and k_s 0 (no
  // lobe seen), not wherever the solver left them (the two solvers leave them at opposite bounds).
  Core c = res.determined ? res.c : global;
  if (res.determined && res.sigma[6] >= kUnmovedSigma) c.logn = global.logn;
  for (int k = 0; k < 3; ++k)
    if (res.determined && res.sigma[3 + k] >= kUnmovedSigma) c.ks[k] = 0;
  for (int k = 0; k < 3; ++k) {
    m->kd[3 * t + k] = c.kd[k];
    m->ks[3 * t + k] = c.ks[k];
    m->kd_sigma[3 * t + k] = res.determined ? res.sigma[k] : prior_sigma("kd");
    m->ks_sigma[3 * t + k] = res.determined ? res.sigma[3 + k] : prior_sigma("ks");
  }
  m->residual[t] = res.values > 0 ? std::sqrt(res.rss / res.values) : -1;
  m->n[t] = std::exp(c.logn);
  m->n_sigma[t] = res.determined ? m->n[t] * res.sigma[6] : prior_sigma("n");
  m->psi_deg[t] = wrap_fiber_deg(rad_to_deg(c.psi));
  m->psi_sigma_deg[t] = res.determined ? rad_to_deg(res.sigma[7]) : 180 / std::sqrt(12.0);
  if (!m->s.empty()) {
    m->s[t] = res.determined ? res.s : s;
    m->s_sigma[t] = res.determined ? res.sigma[8] : prior_sigma(s_param);
  }
}

// The rows of the grid a tile holds: entry b is texel (b % w, row0 + b / w).
struct BandGrid {
  int w, row0, row1;
};

// The prior of entry b for the next sweep: its 4 neighbours' values of this sweep (those the data
// determined; with `with_s` their s too), weights lambda x neighbours / (H^-1)_kk from the
// texel's first, unpulled fit.
bool smoothing_prior(const TexelResults& now, const TexelResults& first, const BandGrid& g,
                     size_t b, double lambda, bool with_s, TexelPrior* p) {
  const int x = static_cast<int>(b % g.w), y = g.row0 + static_cast<int>(b / g.w);
  const Vec8 self = pack_core(now[b].c);
  Vec8 sum = Vec8::Zero();
  double sum_s = 0;
  int count = 0;
  const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
  for (int k = 0; k < 4; ++k) {
    const int nx = x + dx[k], ny = y + dy[k];
    if (nx < 0 || ny < g.row0 || nx >= g.w || ny >= g.row1) continue;
    const TexelResult& nb = now[static_cast<size_t>(ny - g.row0) * g.w + nx];
    if (!nb.determined) continue;
    Vec8 v = pack_core(nb.c);
    v(7) = self(7) + std::remainder(v(7) - self(7), M_PI);
    sum += v;
    sum_s += nb.s;
    ++count;
  }
  if (count == 0) return false;
  p->b = sum / count;
  const double s2 = first[b].rss / std::max(first[b].values - 8, 1.0);
  auto weight = [&](double sigma) { return lambda * count * s2 / std::max(sigma * sigma, 1e-300); };
  for (int k = 0; k < 8; ++k) p->w(k) = weight(first[b].sigma[k]);
  if (with_s) p->bs = sum_s / count, p->ws = weight(first[b].sigma[8]);
  return true;
}

}  // namespace

TileRows rows_with_reach(int row0, int row1, const FitOptions& opt) {
  // Smoothing: a tile also fits `sweeps` rows beyond its band; after that many sweeps the error
  // of the missing rows beyond has moved in by as many rows and stops short of the band.
  const int reach = opt.maps_smooth > 0 ? opt.maps_sweeps : 0;
  return {row0, row1, std::max(0, row0 - reach), std::min(opt.maps_h, row1 + reach)};
}

TileRows tile_rows(const FitOptions& opt) {
  if (opt.tile_count == 0) return rows_with_reach(0, opt.maps_h, opt);
  const long h = opt.maps_h;
  return rows_with_reach(static_cast<int>(h * opt.tile_index / opt.tile_count),
                         static_cast<int>(h * (opt.tile_index + 1) / opt.tile_count), opt);
}

namespace {

// The result's arrays for rows [row0, row1) of the grid.
void size_maps(size_t texels, bool fit_s, TexelMaps* m) {
  for (auto* v : {&m->kd, &m->ks, &m->kd_sigma, &m->ks_sigma}) v->assign(3 * texels, 0);
  for (auto* v : {&m->n, &m->psi_deg, &m->n_sigma, &m->psi_sigma_deg, &m->residual})
    v->assign(texels, 0);
  if (fit_s)
    m->s.assign(texels, 0), m->s_sigma.assign(texels, 0);
  else
    m->s.clear(), m->s_sigma.clear();
  m->pixels.assign(texels, 0);
  m->determined.assign(texels, 0);
}

// Each texel's observations in order, for the texels [t_begin, t_end) of the grid, in one array
// of 4-byte indices (the loader keeps fewer than 2^32 records), texel b's from at[b] to at[b + 1]
// (a list per texel took 8 bytes an observation and a million allocations). A counting sort in two
// levels, stable at both: each observation's index goes first to its band of 2^shift texels
// (one stream per band, written in order), then each band is sorted by texel in a buffer that stays
// in cache, where placing each index at once at its texel writes at random over the whole array.
// `idx` is left unwritten until placed: the threads fault its pages in, not a serial zero fill
// (docs/solver-rules.md "Texels binned").
struct TexelBins {
  std::vector<uint32_t, RecordAllocator<uint32_t>> idx;
  std::vector<size_t> at;
  size_t size(size_t b) const { return at[b + 1] - at[b]; }
  // Texel b's observations as the solvers take them.
  const std::vector<size_t>& list(size_t b) const {
    thread_local std::vector<size_t> out;
    out.assign(idx.begin() + static_cast<std::ptrdiff_t>(at[b]),
               idx.begin() + static_cast<std::ptrdiff_t>(at[b + 1]));
    return out;
  }
};

// Bands of 4096 texels (~1.3 MB of indices at 80 pixels a texel), or smaller on a small grid: at
// least eight a thread, so that the second level is spread over the threads too.
int band_shift(size_t B, size_t parts) {
  int shift = 12;
  while (shift > 6 && (B >> shift) < 8 * parts) --shift;
  return shift;
}

// The first level: idx holds each band's indices in order, band k's from band_at[k].
void bin_by_band(const std::vector<uint32_t, RecordAllocator<uint32_t>>& texel, uint32_t first,
                 size_t B, size_t parts, int shift, TexelBins* bins, std::vector<size_t>* band_at) {
  const size_t bands = (B + (size_t{1} << shift) - 1) >> shift, n = texel.size();
  // Part p's observations [n p / parts, n (p + 1) / parts) and its count (then its next place)
  // per band at next[p][k].
  std::vector<std::vector<size_t>> next(parts, std::vector<size_t>(bands, 0));
  auto for_part = [&](size_t p, auto&& f) {
    for (size_t i = n * p / parts, end = n * (p + 1) / parts; i < end; ++i) {
      const uint32_t b = texel[i] - first;
      if (b < B) f(i, b >> shift);
    }
  };
  tbb::parallel_for(size_t{0}, parts,
                    [&](size_t p) { for_part(p, [&](size_t, uint32_t k) { ++next[p][k]; }); });
  band_at->assign(bands + 1, 0);
  size_t sum = 0;  // band by band, in each the parts in order: stable
  for (size_t k = 0; k < bands; ++k) {
    (*band_at)[k] = sum;
    for (size_t p = 0; p < parts; ++p) sum += std::exchange(next[p][k], sum);
  }
  (*band_at)[bands] = sum;
  bins->idx.resize(sum);
  tbb::parallel_for(size_t{0}, parts, [&](size_t p) {
    for_part(p, [&](size_t i, uint32_t k) { bins->idx[next[p][k]++] = static_cast<uint32_t>(i); });
  });
}

// *bins (its index array's allocation reused) for the texels [t_begin, t_end).
void texel_bins(const ObsSet& os, size_t t_begin, size_t t_end, TexelBins* out) {
  if (os.obs.size() >= UINT32_MAX) throw Error("fit --maps: 2^32 pixels or more; use --subsample");
  const size_t B = t_end - t_begin;
  // Texel t is entry t - t_begin, in 32 bits: a texel before t_begin wraps past every entry, as
  // does kNoTexel (a grid has at most 16384^2 texels, so t_end is far below 2^32).
  const auto first = static_cast<uint32_t>(t_begin);
  TexelBins& bins = *out;
  std::vector<size_t> band_at;
  const size_t parts = static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const int shift = band_shift(B, parts);
  bin_by_band(os.texel, first, B, parts, shift, &bins, &band_at);
  bins.at.resize(B + 1);
  bins.at[B] = band_at.back();
  tbb::parallel_for(size_t{0}, band_at.size() - 1, [&](size_t k) {
    const size_t t0 = k << shift, nt = std::min(size_t{1} << shift, B - t0);
    const size_t j0 = band_at[k], j1 = band_at[k + 1];
    thread_local std::vector<uint32_t> count, sorted;
    count.assign(nt + 1, 0);
    for (size_t j = j0; j < j1; ++j) ++count[os.texel[bins.idx[j]] - first - t0 + 1];
    for (size_t t = 0; t < nt; ++t) count[t + 1] += count[t];
    for (size_t t = 0; t < nt; ++t) bins.at[t0 + t] = j0 + count[t];
    sorted.resize(j1 - j0);
    for (size_t j = j0; j < j1; ++j) {
      const uint32_t i = bins.idx[j];
      sorted[count[os.texel[i] - first - t0]++] = i;
    }
    std::copy(sorted.begin(), sorted.end(), bins.idx.begin() + static_cast<std::ptrdiff_t>(j0));
  });
}

}  // namespace

struct TexelScratch {
  TexelBins bins;
  TexelResults first;
  TexelMaps maps;  // the band before's, its arrays' allocations for the next
};

std::shared_ptr<TexelScratch> texel_scratch() { return std::make_shared<TexelScratch>(); }

void reuse_maps(TexelScratch* scratch, TexelMaps&& done) { scratch->maps = std::move(done); }

TexelMaps fit_texel_maps(const ObsSet& os, const Core& global, const TexelMapOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const int w = o.w, h = o.h;
  TexelMaps m;
  if (o.scratch) {  // the arrays of the band before (size_maps writes every entry over)
    for (const auto& arr : kTexelArrays) (m.*arr.d).swap(o.scratch->maps.*arr.d);
    m.pixels.swap(o.scratch->maps.pixels);
    m.determined.swap(o.scratch->maps.determined);
  }
  m.w = w;
  m.h = h;
  m.row0 = o.rows.row0;
  m.row1 = o.rows.row1;
  const bool smooth = o.smooth > 0;
  m.smooth = smooth ? o.smooth : 0;
  m.sweeps = smooth ? o.sweeps : 0;
  // Only the rows fitted are held: texel t of the grid is entry t - t_begin below.
  const int band0 = o.rows.band0, band1 = o.rows.band1;
  const size_t t_begin = static_cast<size_t>(band0) * w, t_end = static_cast<size_t>(band1) * w;
  const size_t B = t_end - t_begin;
  TexelScratch own;  // a plain fit's, freed with it
  TexelScratch& scratch = o.scratch ? *o.scratch : own;
  // Bands: room for the largest band at once (mapped pages, only those written touched).
  scratch.bins.idx.reserve(os.obs.capacity());
  texel_bins(os, t_begin, t_end, &scratch.bins);
  const TexelBins& bins = scratch.bins;
  Progress bar("fit --maps: texels", B * (1 + m.sweeps), o.progress);
  auto solve = [&](size_t b, const TexelResult& from, const TexelPrior* prior) {
    if (o.fiber_order > 0) {
      // A fiber texel's quadrature order: the smallest its own values allow (FiberOrderErrors), at
      // most the global fit's; the same in a plain run, its bands and tiles (the texel's pixels
      // are).
      const double values = 3.0 * static_cast<double>(bins.size(b));
      TexelMapOptions ot = o;
      ot.fiber_order = o.fiber_order_errors.order_for(values, o.fiber_order);
      auto fiber = [&] {
        TexelResult t = o.ceres ? solve_texel_fiber_ceres(os, bins.list(b), from, ot, prior)
                                : solve_texel_fiber(os, bins.list(b), from, ot, prior);
        t.quadrature_order = ot.fiber_order;
        return t;
      };
      TexelResult t = fiber();
      // The global fit measured the orders' errors at its own lobe; a texel's own (its n, k_s,
      // psi, the views it has) may need more nodes: it is checked at its own solution against the
      // global fit's order, and solved at that order where the lower one misses the allowance.
      if (ot.fiber_order < o.fiber_order &&
          !fiber_order_holds(os, bins.list(b), t, ot.fiber_order, o.fiber_order,
                             o.fiber_order_errors.allowed(values))) {
        ot.fiber_order = o.fiber_order;
        t = fiber();
      }
      return t;
    }
    return o.ceres
               ? solve_texel_ceres(os, bins.list(b), from.c, prior, o.max_iterations)
               : solve_texel_lm(os, bins.list(b), from.c, prior, o.max_iterations, o.wide_lanes);
  };
  TexelResult start;  // the global fit
  start.c = global;
  start.s = o.s;
  // Every texel alone, each entry written first by the thread that solves it (~170 MB for a
  // 1024^2 map: filled with the start ahead of the threads, one core would fault it all in).
  TexelResults& first = scratch.first;
  if (o.scratch) first.reserve(static_cast<size_t>(h) * w);  // every band's room at once
  first.resize(B);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, B, 4), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); ++b)
      first[b] = bins.size(b) >= kMinTexelPixels ? solve(b, start, nullptr) : start;
    bar.advance(r.size());  // once a range: a shared counter bumped by every texel on both cores
  });
  const bool fit_s = o.fiber_order > 0 && os.topology != TopologyMode::kMathematical;
  // Without sweeps `first` is the result as it is (a copy would be 200 bytes a texel to fault in).
  TexelResults copy;
  if (m.sweeps > 0) copy = first;
  TexelResults& now = m.sweeps > 0 ? copy : first;
  const BandGrid grid{w, band0, band1};
  for (int sweep = 0; sweep < m.sweeps; ++sweep) {
    TexelResults next = now;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, B, 4),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t b = r.begin(); b < r.end(); ++b) {
                          TexelPrior prior;
                          if (first[b].determined &&
                              smoothing_prior(now, first, grid, b, o.smooth, fit_s, &prior))
                            next[b] = solve(b, now[b], &prior);
                        }
                        bar.advance(r.size());
                      });
    now.swap(next);
  }
  const size_t a = static_cast<size_t>(m.row0) * w - t_begin;
  size_maps(static_cast<size_t>(m.row1 - m.row0) * w, fit_s, &m);
  if (os.topology == TopologyMode::kAmplitude) m.s_key = "amplitude";
  double sr = 0, sv = 0;
  for (size_t t = 0; t < m.pixels.size(); ++t) {
    const size_t b = a + t;
    m.pixels[t] = static_cast<int>(bins.size(b));
    if (bins.size(b) >= kMinTexelPixels) {
      ++m.fitted, sr += now[b].rss, sv += now[b].values;
      if (!now[b].converged) ++m.not_converged;
      if (o.fiber_order > 0) ++m.texels_by_order[now[b].quadrature_order];
    }
    put_texel(now[b], t, global, o.s, texel_topology_key(os.topology), &m);
  }
  m.sum_sq = sr, m.values = sv;
  m.rms = sv > 0 ? std::sqrt(sr / sv) : 0;
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  m.threads = tbb::this_task_arena::max_concurrency();
  m.lanes = o.fiber_order == 0 && !o.ceres ? texel_float_lanes(os.simd, o.wide_lanes)
                                           : 0;  // the line model's LM
  return m;
}

void join_band(const TexelMaps& part, int row0, int row1, TexelMaps* whole) {
  const size_t w = static_cast<size_t>(part.w);
  if (whole->pixels.empty()) {  // the first band: the whole's shape from it
    *whole = TexelMaps{};
    whole->w = part.w, whole->h = part.h, whole->row0 = row0, whole->row1 = row1;
    whole->smooth = part.smooth, whole->sweeps = part.sweeps, whole->s_key = part.s_key;
    size_maps(static_cast<size_t>(row1 - row0) * w, !part.s.empty(), whole);
  }
  if (part.row0 < row0 || part.row1 > row1 || part.w != whole->w)
    throw Error("fit --maps: a band's rows outside the maps'");
  const size_t at = static_cast<size_t>(part.row0 - row0) * w;
  for (const auto& arr : kTexelArrays)
    std::copy((part.*arr.d).begin(), (part.*arr.d).end(), (whole->*arr.d).begin() + arr.k * at);
  std::copy(part.pixels.begin(), part.pixels.end(), whole->pixels.begin() + at);
  std::copy(part.determined.begin(), part.determined.end(), whole->determined.begin() + at);
  whole->fitted += part.fitted;
  whole->not_converged += part.not_converged;
  for (int k = 0; k <= FiberOrderErrors::kMaxOrder; ++k)
    whole->texels_by_order[k] += part.texels_by_order[k];
  whole->sum_sq += part.sum_sq;
  whole->values += part.values;
  whole->rms = whole->values > 0 ? std::sqrt(whole->sum_sq / whole->values) : 0;
  whole->seconds += part.seconds;
  whole->threads = std::max(whole->threads, part.threads);
  whole->lanes = std::max(whole->lanes, part.lanes);
}

}  // namespace aniso::fitting
