// Google Benchmark micro-benchmarks: model evaluation in double and in Jets, the fiber model at
// several accuracy settings next to the brute-force reference, a bake, and the residual-plus-
// Jacobian work of one fit iteration per observation. Run: ./build/bench/aniso_microbench
#include <benchmark/benchmark.h>
#include <ceres/jet.h>

#include <random>
#include <vector>

#include "models/evaluate.h"
#include "models/fiber_model.h"
#include "models/fiber_reference.h"
#include "render/bake.h"

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

}  // namespace

BENCHMARK_MAIN();
