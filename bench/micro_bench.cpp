// Google Benchmark micro-benchmarks: model evaluation in double and in Jets, the fiber model at
// several accuracy settings next to the brute-force reference, a bake, and the residual-plus-
// Jacobian work of one fit iteration per observation. Run: ./build/bench/aniso_microbench
#include <benchmark/benchmark.h>
#include <ceres/jet.h>

#include <random>
#include <vector>

#include "fit/solvers/line_pixel_lanes.h"
#include "fit/solvers/line_solve.h"
#include "fit/solvers/start.h"
#include "fit/solvers/texel_lanes.h"
#include "models/evaluate.h"
#include "models/fiber_model.h"
#include "models/fiber_reference.h"
#include "render/bake/bake.h"

namespace {

using namespace aniso;

std::vector<LocalDir> dirs(size_t n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<LocalDir> out;
  for (size_t i = 0; i < n; ++i) {
    const double x = g(rng), y = g(rng), z = std::abs(g(rng)), l = std::sqrt(x * x + y * y + z * z);
    out.push_back({x / l, y / l, z / l});
  }
  return out;
}

Material material(const char* model) {
  Material m;
  m.model = std::string(model) == "fiber" ? Model::kFiber : Model::kLine;
  m.kd = {0.2, 0.2, 0.2};
  m.ks = {0.6, 0.6, 0.6};
  m.n = 40;
  m.fiber_angle_deg = 30;
  m.topology = UniformS{0.5};
  return m;
}

void BM_LineDouble(benchmark::State& st) {
  const auto d = dirs(1024, 1);
  const Evaluator e(material("line"));
  size_t i = 0;
  for (auto _ : st) {
    double f[3];
    e(d[i & 1023], d[(i + 1) & 1023], f);
    benchmark::DoNotOptimize(f);
    ++i;
  }
}
BENCHMARK(BM_LineDouble);

// A Jet over the 8 fitted numbers (k_d, k_s, log n, psi): the autodiff cost per observation.
void BM_LineJet8(benchmark::State& st) {
  using J = ceres::Jet<double, 8>;
  const auto d = dirs(1024, 2);
  LineParamsT<J> p;
  for (int k = 0; k < 3; ++k) p.kd[k] = J(0.2, k), p.ks[k] = J(0.6, 3 + k);
  p.n = exp(J(std::log(40.0), 6));
  p.psi = J(0.5, 7);
  size_t i = 0;
  for (auto _ : st) {
    J f[3];
    line_reflectance(p, d[i & 1023], d[(i + 1) & 1023], f);
    benchmark::DoNotOptimize(f);
    ++i;
  }
}
BENCHMARK(BM_LineJet8);

void BM_FiberOrder(benchmark::State& st) {
  const auto d = dirs(1024, 3);
  const Evaluator e(material("fiber"), FiberAccuracy{static_cast<int>(st.range(0))});
  size_t i = 0;
  for (auto _ : st) {
    double f[3];
    e(d[i & 1023], d[(i + 1) & 1023], f);
    benchmark::DoNotOptimize(f);
    ++i;
  }
}
BENCHMARK(BM_FiberOrder)->Arg(2)->Arg(4)->Arg(8)->Arg(16);

void BM_FiberJet9(benchmark::State& st) {
  using J = ceres::Jet<double, 9>;
  const auto d = dirs(1024, 4);
  LineParamsT<J> p;
  for (int k = 0; k < 3; ++k) p.kd[k] = J(0.2, k), p.ks[k] = J(0.6, 3 + k);
  p.n = exp(J(std::log(40.0), 6));
  p.psi = J(0.5, 7);
  const J s(0.5, 8);
  size_t i = 0;
  for (auto _ : st) {
    J f[3];
    fiber_reflectance(p, s, d[i & 1023], d[(i + 1) & 1023], FiberAccuracy{}, f);
    benchmark::DoNotOptimize(f);
    ++i;
  }
}
BENCHMARK(BM_FiberJet9);

void BM_FiberBruteForce(benchmark::State& st) {
  const auto d = dirs(64, 5);
  size_t i = 0;
  for (auto _ : st) {
    const LocalDir &L = d[i & 63], &V = d[(i + 1) & 63];
    benchmark::DoNotOptimize(
        reference::fiber_bruteforce(L.w, L.n, V.w, V.n, L.u, V.u, 40.0, 0.5, 4000));
    ++i;
  }
}
BENCHMARK(BM_FiberBruteForce)->Unit(benchmark::kMillisecond);

void BM_Bake(benchmark::State& st) {
  const Material m = material("line");
  for (auto _ : st)
    benchmark::DoNotOptimize(bake_line(m, static_cast<int>(st.range(0))).combined.px.data());
}
BENCHMARK(BM_Bake)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);

// The global fit's pass over `range(0)` observations of one light (fit/solvers/line_solve.h
// line_chunk, with J^T J and J^T r, no robust loss): four at a time in AVX2 lanes (range(1) 1) or
// one at a time (0), the same equation (fit/solvers/line_equation.inc).
void BM_LinePass(benchmark::State& st) {
  const size_t count = static_cast<size_t>(st.range(0));
  if (st.range(1) == 1 && !fitting::line_lanes_on(true)) return st.SkipWithError("no AVX2 and FMA");
  const auto v = dirs(count, 8), l = dirs(count, 9);
  fitting::ObsSet os;
  os.simd = st.range(1) == 1;
  for (size_t j = 0; j < count; ++j) {
    fitting::Observation o;
    o.V = v[j];
    o.first_light = static_cast<uint32_t>(j);
    o.num_lights = 1;
    fitting::ObsLight li;
    li.L = l[j];
    for (int k = 0; k < 3; ++k)
      li.E[k] = 16.0, o.y[k] = static_cast<float>(0.2 * 16 * l[j].n + 0.1);
    os.obs.push_back(o);
    os.lights.push_back(li);
  }
  const double kd[3] = {0.2, 0.2, 0.2}, ks[3] = {0.6, 0.6, 0.6};
  const fitting::LinePixelParams p{kd, ks, 40.0, std::cos(0.5), std::sin(0.5)};
  const fitting::RobustLoss none{FitLoss::kNone, 0};
  for (auto _ : st) {
    fitting::ChannelSums<8> s;
    fitting::line_chunk(os, nullptr, 0, count, p, none, true, &s, nullptr);
    benchmark::DoNotOptimize(s);
  }
  st.counters["ns_per_obs"] =
      benchmark::Counter(static_cast<double>(st.iterations() * st.range(0)),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_LinePass)->ArgsProduct({{4096}, {0, 1}});

// One texel of --maps in float lanes (fit/solvers/texel_lanes.h): the pass with J^T J and J^T r,
// and the eight start nodes (n = 2^4, the power of two nearest that set's global n, 15.7), over
// `range(0)` observations under one grey light (80: the mean texel of a 1024^2 map from 64 views
// of 2048^2).
fitting::TexelLanes texel_lanes_of(size_t count) {
  const auto v = dirs(count, 6), l = dirs(count, 7);
  fitting::TexelLanes t;
  t.count = count;
  t.groups = (count + 7) / 8;
  t.f.assign(fitting::TexelLanes::stored_groups(t.groups) * fitting::TexelLanes::kRows * 8, 0.f);
  t.grey_light = true;
  for (size_t j = 0; j < count; ++j) {
    const double E = 16.0 * l[j].n, y = 0.2 * E + 0.1;
    const double row[fitting::TexelLanes::kRows] = {v[j].u, v[j].w, l[j].u, l[j].w, l[j].n, E,
                                                    E,      E,      y,      y,      y,      1};
    for (int k = 0; k < fitting::TexelLanes::kRows; ++k)
      t.f[((j / 8) * fitting::TexelLanes::kRows + k) * 8 + j % 8] = static_cast<float>(row[k]);
  }
  return t;
}

// range(1): the lanes' width, 8 (AVX2) or 16 (AVX-512, where the CPU has it).
bool texel_width(benchmark::State& st) {
  if (!fitting::line_lanes_on(true)) return st.SkipWithError("no AVX2 and FMA"), false;
  if (st.range(1) == 16 && !fitting::texel_avx512_available())
    return st.SkipWithError("no AVX-512 on this CPU"), false;
  return true;
}

void BM_TexelPassF32(benchmark::State& st) {
  if (!texel_width(st)) return;
  fitting::TexelLanes t = texel_lanes_of(static_cast<size_t>(st.range(0)));
  t.wide = st.range(1) == 16;
  const double kd[3] = {0.2, 0.2, 0.2}, ks[3] = {0.6, 0.6, 0.6};
  const fitting::LinePixelParams p{kd, ks, 40.0, std::cos(0.5), std::sin(0.5)};
  for (auto _ : st) {
    fitting::ChannelSums<8> s;
    fitting::texel_pass_f32(t, p, true, &s);
    benchmark::DoNotOptimize(s);
  }
  st.counters["ns_per_obs"] =
      benchmark::Counter(static_cast<double>(st.iterations() * st.range(0)),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_TexelPassF32)->ArgsProduct({{80, 640}, {8, 16}});

void BM_TexelNodesF32(benchmark::State& st) {
  if (!texel_width(st)) return;
  fitting::TexelLanes t = texel_lanes_of(static_cast<size_t>(st.range(0)));
  t.wide = st.range(1) == 16;
  double psi[8];  // the start grid's first eight nodes
  for (int k = 0; k < 8; ++k) psi[k] = fitting::texel_grid_angle(4 * k);
  for (auto _ : st) {
    fitting::KdKsSums sums[8];
    fitting::texel_nodes_f32(t, psi, 4, sums);
    benchmark::DoNotOptimize(sums);
  }
  st.counters["ns_per_obs"] =
      benchmark::Counter(static_cast<double>(st.iterations() * st.range(0)),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_TexelNodesF32)->ArgsProduct({{80, 640}, {8, 16}});

}  // namespace

BENCHMARK_MAIN();
