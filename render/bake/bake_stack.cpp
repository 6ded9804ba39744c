// The line model's specular tables at many n (render/bake/bake.h: SpecularStack).
#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "core/error.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/images/image_io.h"
#include "models/line_model.h"
#include "render/bake/bake.h"

namespace aniso {

namespace {

// The smallest and largest finite positive value of channel 0 of `img`; false where there is none.
bool map_range(const Image& img, double* lo, double* hi) {
  *lo = INFINITY, *hi = -INFINITY;
  for (size_t p = 0; p < img.px.size(); p += img.channels) {
    const double v = img.px[p];
    if (std::isfinite(v) && v > 0) *lo = std::min(*lo, v), *hi = std::max(*hi, v);
  }
  return *lo <= *hi;
}

}  // namespace

SpecularStack bake_specular_stack(double n_min, double n_max, int size, BakeIndex index,
                                  double max_log_step, int max_levels, uint64_t seed) {
  if (!(n_min > 0 && n_max >= n_min && std::isfinite(n_max)))
    throw Error("bake: the map of n must hold finite positive values (range " +
                std::to_string(n_min) + " to " + std::to_string(n_max) + ")");
  SpecularStack st;
  st.size = size;
  st.index = index;
  st.seed = seed;
  st.logn0 = std::log(n_min);
  st.logn1 = std::log(n_max);
  const int steps = static_cast<int>(std::ceil((st.logn1 - st.logn0) / max_log_step - 1e-9));
  st.levels = std::clamp(steps + 1, 2, max_levels);
  Image D(size, size, 1);  // the same at every n: for the diffuse part's lookup error
  for (int j = 0; j < size; ++j)
    for (int i = 0; i < size; ++i) {
      double d, s;
      line_DS(texel_cosine(i, size, index), texel_cosine(j, size, index), 1.0, &d, &s);
      D.at(i, j, 0) = static_cast<float>(d);
    }
  for (int k = 0; k < st.levels; ++k) {
    const double n = std::exp(st.logn0 + k * st.log_step());
    Image S(size, size, 1);
    for (int j = 0; j < size; ++j)
      for (int i = 0; i < size; ++i) {
        double d, s;
        line_DS(texel_cosine(i, size, index), texel_cosine(j, size, index), n, &d, &s);
        S.at(i, j, 0) = static_cast<float>(s);
      }
    st.max_texel_step = std::max(st.max_texel_step, max_texel_step(S));
    st.S.push_back(std::move(S));
  }
  // The error of the lookup: random (a, b) at random n, plus the ridge b = -a where the lobe is
  // sharpest, as bake_line measures its tables.
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), t(0.0, 1.0);
  auto check = [&](double a, double b) {
    const double n = std::exp(st.logn0 + t(rng) * (st.logn1 - st.logn0));
    double d, s;
    line_DS(a, b, n, &d, &s);
    st.max_abs_error = std::max(st.max_abs_error, std::abs(stack_lookup(st, a, b, n) - s));
    st.diffuse_max_abs_error =
        std::max(st.diffuse_max_abs_error, std::abs(lookup_bilinear(D, a, b, 0, index) - d));
    ++st.samples;
  };
  constexpr int kRandomSamples = 100000, kRidgeSamples = 20000;
  for (int k = 0; k < kRandomSamples; ++k) check(u(rng), u(rng));
  for (int k = 0; k < kRidgeSamples; ++k) {
    const double a = u(rng);
    check(a, std::clamp(-a + 0.02 * u(rng), -1.0, 1.0));
  }
  return st;
}

SpecularStack bake_material_stack(const Material& m, int size, BakeIndex index, double max_log_step,
                                  int max_levels) {
  double lo = m.n, hi = m.n;
  if (m.maps.n && !map_range(*m.maps.n, &lo, &hi))
    throw Error("bake: the material's map of n (" + m.maps.n_file + ") holds no positive value");
  return bake_specular_stack(lo, hi, size, index, max_log_step, max_levels);
}

double stack_lookup(const SpecularStack& st, double a, double b, double n) {
  const double f = st.log_step() > 0 ? std::clamp((std::log(n) - st.logn0) / st.log_step(), 0.0,
                                                  double(st.levels - 1))
                                     : 0.0;
  const int k0 = std::min(static_cast<int>(f), std::max(st.levels - 2, 0));
  const double w = f - k0;
  const double s0 = lookup_bilinear(st.S[k0], a, b, 0, st.index);
  return st.levels > 1 ? s0 + w * (lookup_bilinear(st.S[k0 + 1], a, b, 0, st.index) - s0) : s0;
}

std::vector<float> stack_levels(const SpecularStack& st) {
  std::vector<float> v;
  v.reserve(static_cast<size_t>(st.size) * st.size * st.levels);
  for (const Image& t : st.S) v.insert(v.end(), t.px.begin(), t.px.end());
  return v;
}

nlohmann::json write_specular_stack(const std::string& dir, const SpecularStack& st) {
  Image levels(st.size, st.size * st.levels, 1);
  levels.px = stack_levels(st);
  write_exr(join_path(dir, "specular_stack.exr"), levels);
  return {{"file", "specular_stack.exr"},
          {"layout",
           "width size, rows size * levels: level k's row j at k * size + j, indexed as "
           "specular"},
          {"levels", st.levels},
          {"log_n0", st.logn0},
          {"log_n1", st.logn1},
          {"n", "level k at n = exp(log_n0 + k (log_n1 - log_n0) / (levels - 1))"},
          {"lookup",
           "f = (log n - log_n0) / step clamped to [0, levels - 1]; S bilinear from level "
           "min(floor(f), levels - 2) and the next, blended by f less that level"},
          {"error",
           {{"against", "S(a, b; n) at random n in the range, random (a, b) and the ridge"},
            {"max_abs", st.max_abs_error},
            {"diffuse_max_abs", st.diffuse_max_abs_error},
            {"max_texel_step", st.max_texel_step},
            {"samples", st.samples},
            {"seed", st.seed}}}};
}

SpecularStack read_specular_stack(const nlohmann::json& f, const std::string& file,
                                  const BakeTables& t) {
  const jsonu::Ctx c{file, "specular_stack"};
  SpecularStack st;
  const double levels = jsonu::num(jsonu::need(f, "levels", c), c.at("levels"));
  if (levels < 2 || levels > 4096 || levels != std::floor(levels))
    c.at("levels").fail("must be an integer in [2, 4096]");
  st.levels = static_cast<int>(levels);
  st.size = t.size;
  st.index = t.index;
  st.logn0 = jsonu::num(jsonu::need(f, "log_n0", c), c.at("log_n0"));
  st.logn1 = jsonu::num(jsonu::need(f, "log_n1", c), c.at("log_n1"));
  if (!(st.logn1 >= st.logn0)) c.at("log_n1").fail("must be at least log_n0");
  const nlohmann::json& e = jsonu::need(f, "error", c);
  const jsonu::Ctx ce = c.at("error");
  st.max_abs_error = jsonu::num(jsonu::need(e, "max_abs", ce), ce.at("max_abs"));
  st.diffuse_max_abs_error = jsonu::num_or(e, "diffuse_max_abs", 0, ce);
  st.max_texel_step = jsonu::num_or(e, "max_texel_step", 0, ce);
  const std::string name = jsonu::str(jsonu::need(f, "file", c), c.at("file"));
  const Image all = read_image(join_path(parent_dir(file), name), t.size, t.size * st.levels).image;
  if (all.channels != 1) c.at("file").fail(name + " must hold one channel");
  const size_t level = static_cast<size_t>(t.size) * t.size;
  for (int k = 0; k < st.levels; ++k) {
    Image S(t.size, t.size, 1);
    std::copy(all.px.begin() + k * level, all.px.begin() + (k + 1) * level, S.px.begin());
    st.S.push_back(std::move(S));
  }
  return st;
}

}  // namespace aniso
