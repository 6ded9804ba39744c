#include "fit/fit.h"

#include <ceres/ceres.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/angles.h"
#include "core/error.h"
#include "core/frame.h"
#include "core/progress.h"
#include "core/texture.h"
#include "io/files.h"
#include "io/image_io.h"
#include "io/json_util.h"
#include "io/material_io.h"
#include "models/fiber_model.h"
#include "models/line_model.h"
#include "models/params.h"

namespace aniso {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// ---------------------------------------------------------------------------------------------
// Observations: one per pixel (three channels), its lights already reduced to local directions
// and irradiance scales (exposure folded in). Lights below the horizon are dropped here: they
// contribute exactly zero, so the fit never evaluates them.
struct ObsLight {
  LocalDir L;
  double E[3];
};
struct Observation {
  LocalDir V;
  uint32_t first_light = 0, num_lights = 0;
  double y[3];                 // measured value
  double base[3];              // known constant part (ambient times k_a, which is not fitted)
  double smath = 0, mapv = 0;  // fiber model: mathematical topology and map value at the pixel
  double u = 0, v = 0;         // texture coordinates (per-texel topology fits)
};
// How the fiber model's topology enters: one s for the whole sample, the map amplitude A on top
// of per-pixel s_math and map values, or s_math alone (nothing to fit).
enum class TopologyMode { kGlobalS, kAmplitude, kMathematical, kTexels };
struct ObsSet {
  std::vector<Observation> obs;
  std::vector<ObsLight> lights;
  TopologyMode topology = TopologyMode::kGlobalS;
  int texels = 0;            // kTexels: an N x N map of s over uv
  std::string topology_map;  // recorded in the result
  MathTopology topology_mathematical = MathTopology::kNone;
  bool grey = false;  // a grey table: the three channels repeat one value
  // Noise of the images themselves, from differences of neighbouring pixels (robust, so edges
  // and the smooth shading between neighbours hardly count); 0 where there are no images.
  double pixel_noise = 0;
};

// ---------------------------------------------------------------------------------------------
// The model parameters from the fitted blocks (k_d, k_s, log n, psi).
template <class T>
LineParamsT<T> fitted_params(const T* kd, const T* ks, const T* logn, const T* psi) {
  using std::exp;
  LineParamsT<T> p;
  for (int k = 0; k < 3; ++k) {
    p.kd[k] = kd[k];
    p.ks[k] = ks[k];
  }
  p.n = exp(logn[0]);
  p.psi = psi[0];
  return p;
}

// residual = known part + sum over the pixel's lights of E * reflectance(L, V) - y.
template <class T, class Reflectance>
void pixel_residual(const Observation* obs, const ObsLight* lights, Reflectance reflectance, T* r) {
  T acc[3] = {T(obs->base[0]), T(obs->base[1]), T(obs->base[2])};
  for (uint32_t i = 0; i < obs->num_lights; ++i) {
    const ObsLight& l = lights[obs->first_light + i];
    T f[3];
    reflectance(l.L, obs->V, f);
    for (int k = 0; k < 3; ++k) acc[k] += l.E[k] * f[k];
  }
  for (int k = 0; k < 3; ++k) r[k] = acc[k] - obs->y[k];
}

// The residual of one pixel: exposure * I(params) - y, per channel (MODELS.md §2-3).
// Block sizes: kd 3, ks 3, log n 1, psi 1, isotropic (kd 3, ks 3, log n_iso 1) or a 1-wide dummy,
// second fiber (psi2, w) or a 1-wide dummy. Dummies are held constant.
template <bool kIso, bool kSecond>
struct LineResidual {
  LineResidual(const Observation* o, const ObsLight* l) : obs(o), lights(l) {}

  template <class T>
  bool operator()(const T* kd, const T* ks, const T* logn, const T* psi, const T* iso, const T* sec,
                  T* r) const {
    using std::exp;
    LineParamsT<T> p = fitted_params(kd, ks, logn, psi);
    p.isotropic = kIso;
    p.second = kSecond;
    if constexpr (kIso) {
      for (int k = 0; k < 3; ++k) {
        p.kd_iso[k] = iso[k];
        p.ks_iso[k] = iso[3 + k];
      }
      p.n_iso = exp(iso[6]);
    }
    if constexpr (kSecond) {
      p.psi2 = sec[0];
      p.w = sec[1];
    }
    pixel_residual(
        obs, lights,
        [&](const LocalDir& L, const LocalDir& V, T* f) { line_reflectance(p, L, V, f); }, r);
    return true;
  }

  static ceres::CostFunction* Create(const Observation* o, const ObsLight* l) {
    return new ceres::AutoDiffCostFunction < LineResidual, 3, 3, 3, 1, 1, kIso ? 7 : 1,
           kSecond ? 2 : 1 > (new LineResidual(o, l));
  }

  const Observation* obs;
  const ObsLight* lights;
};

// The common case (no optional terms) with hand-written derivatives: the same residual as
// LineResidual<false, false>, about 4x cheaper than Jets of size 8 (tests compare the two).
// d sqrt(1 - a^2)/da uses the same chord as models/safe_math.h below kSqrtChordEps.
class LineResidualAnalytic : public ceres::SizedCostFunction<3, 3, 3, 1, 1, 1, 1> {
 public:
  LineResidualAnalytic(const Observation* o, const ObsLight* l) : obs_(o), lights_(l) {}

  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const double* kd = p[0];
    const double* ks = p[1];
    const double logn = p[2][0], psi = p[3][0];
    const double n = std::exp(logn), c = std::cos(psi), sn = std::sin(psi);
    const LocalDir& V = obs_->V;
    const double b = clamp_unit(c * V.u + sn * V.w), db = -sn * V.u + c * V.w;
    double sV, dsV;
    sin_and_derivative(b, &sV, &dsV);
    double f[3] = {obs_->base[0], obs_->base[1], obs_->base[2]};
    double dkd[3] = {0, 0, 0}, dks[3] = {0, 0, 0}, dlogn[3] = {0, 0, 0}, dpsi[3] = {0, 0, 0};
    for (uint32_t i = 0; i < obs_->num_lights; ++i) {
      const ObsLight& l = lights_[obs_->first_light + i];
      const double nl = l.L.n;
      const double a = clamp_unit(c * l.L.u + sn * l.L.w), da = -sn * l.L.u + c * l.L.w;
      double sL, dsL;
      sin_and_derivative(a, &sL, &dsL);
      const double x = sL * sV - a * b;
      double S = 0, dS_dx = 0, dS_dlogn = 0;
      if (x > 0) {
        S = std::exp(n * std::log(x));
        dS_dx = n * S / x;
        dS_dlogn = S * n * std::log(x);
      }
      const double dx_dpsi = (dsL * sV - b) * da + (sL * dsV - a) * db;
      const double dD_dpsi = dsL * da;
      for (int k = 0; k < 3; ++k) {
        const double w = l.E[k] * nl;
        f[k] += w * (kd[k] * sL + ks[k] * S);
        dkd[k] += w * sL;
        dks[k] += w * S;
        dlogn[k] += w * ks[k] * dS_dlogn;
        dpsi[k] += w * (kd[k] * dD_dpsi + ks[k] * dS_dx * dx_dpsi);
      }
    }
    for (int k = 0; k < 3; ++k) r[k] = f[k] - obs_->y[k];
    if (!J) return true;
    if (J[0]) std::fill(J[0], J[0] + 9, 0.0);
    if (J[1]) std::fill(J[1], J[1] + 9, 0.0);
    for (int k = 0; k < 3; ++k) {
      if (J[0]) J[0][k * 3 + k] = dkd[k];
      if (J[1]) J[1][k * 3 + k] = dks[k];
      if (J[2]) J[2][k] = dlogn[k];
      if (J[3]) J[3][k] = dpsi[k];
      if (J[4]) J[4][k] = 0;
      if (J[5]) J[5][k] = 0;
    }
    return true;
  }

 private:
  // sqrt(1 - a^2) and its derivative, with the chord of models/safe_math.h near |a| = 1.
  static void sin_and_derivative(double a, double* s, double* ds) {
    const double x = 1 - a * a;
    if (x <= 0) {
      *s = 0;
      *ds = 0;
    } else if (x < kSqrtChordEps) {
      *s = x / std::sqrt(kSqrtChordEps);
      *ds = -2 * a / std::sqrt(kSqrtChordEps);
    } else {
      *s = std::sqrt(x);
      *ds = -a / *s;
    }
  }
  const Observation* obs_;
  const ObsLight* lights_;
};

// Many pixels per residual block (the default line fit): per-block overhead in Ceres, not the
// model, dominated the per-pixel form. Each pixel's three residuals are scaled by sqrt(w_i), the
// weight of iteratively reweighted least squares that reproduces the robust loss per pixel.
class LineChunkResidual : public ceres::CostFunction {
 public:
  LineChunkResidual(std::vector<const Observation*> obs, const ObsLight* lights,
                    const std::vector<double>* sqrt_w, size_t first)
      : obs_(std::move(obs)), lights_(lights), sqrt_w_(sqrt_w), first_(first) {
    set_num_residuals(static_cast<int>(3 * obs_.size()));
    *mutable_parameter_block_sizes() = {3, 3, 1, 1};
  }
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const double dummy_iso = 0, dummy_sec = 0;
    const double* params[6] = {p[0], p[1], p[2], p[3], &dummy_iso, &dummy_sec};
    const int m = num_residuals();
    for (size_t i = 0; i < obs_.size(); ++i) {
      const LineResidualAnalytic one(obs_[i], lights_);
      double ri[3], j0[9], j1[9], j2[3], j3[3];
      double* jac[6] = {j0, j1, j2, j3, nullptr, nullptr};
      one.Evaluate(params, ri, J ? jac : nullptr);
      const double w = (*sqrt_w_)[first_ + i];
      for (int k = 0; k < 3; ++k) r[3 * i + k] = w * ri[k];
      if (!J) continue;
      for (int k = 0; k < 3; ++k) {
        const size_t row = 3 * i + k;
        if (J[0])
          for (int q = 0; q < 3; ++q) J[0][row * 3 + q] = w * j0[k * 3 + q];
        if (J[1])
          for (int q = 0; q < 3; ++q) J[1][row * 3 + q] = w * j1[k * 3 + q];
        if (J[2]) J[2][row] = w * j2[k];
        if (J[3]) J[3][row] = w * j3[k];
      }
    }
    (void)m;
    return true;
  }

 private:
  std::vector<const Observation*> obs_;
  const ObsLight* lights_;
  const std::vector<double>* sqrt_w_;
  size_t first_;
};

// The fiber model's residual (MODELS.md §4): blocks kd 3, ks 3, log n 1, psi 1, topology 1
// (s, or the map amplitude A, or a constant dummy).
struct FiberResidual {
  FiberResidual(const Observation* o, const ObsLight* l, TopologyMode m, FiberAccuracy a)
      : obs(o), lights(l), mode(m), acc(a) {}

  template <class T>
  bool operator()(const T* kd, const T* ks, const T* logn, const T* psi, const T* topo,
                  T* r) const {
    const LineParamsT<T> p = fitted_params(kd, ks, logn, psi);
    T s;
    switch (mode) {
      case TopologyMode::kGlobalS:
        s = topo[0];
        break;
      case TopologyMode::kAmplitude:
        s = topology_with_map(obs->smath, topo[0], obs->mapv);
        break;
      default:
        s = T(obs->smath);
        break;
    }
    pixel_residual(
        obs, lights,
        [&](const LocalDir& L, const LocalDir& V, T* f) { fiber_reflectance(p, s, L, V, acc, f); },
        r);
    return true;
  }

  static ceres::CostFunction* Create(const Observation* o, const ObsLight* l, TopologyMode m,
                                     FiberAccuracy a) {
    return new ceres::AutoDiffCostFunction<FiberResidual, 3, 3, 3, 1, 1, 1>(
        new FiberResidual(o, l, m, a));
  }

  const Observation* obs;
  const ObsLight* lights;
  TopologyMode mode;
  FiberAccuracy acc;
};

// The fiber model with a per-texel map of s: the pixel's s is the bilinear mix (wrap-around, glTF
// uv) of four texel parameters.
struct FiberTexelResidual {
  FiberTexelResidual(const Observation* o, const ObsLight* l, const BilinearTaps& t,
                     FiberAccuracy a)
      : obs(o), lights(l), taps(t), acc(a) {}

  template <class T>
  bool operator()(const T* kd, const T* ks, const T* logn, const T* psi, const T* t0, const T* t1,
                  const T* t2, const T* t3, T* r) const {
    const LineParamsT<T> p = fitted_params(kd, ks, logn, psi);
    const T s = taps.weight[0] * t0[0] + taps.weight[1] * t1[0] + taps.weight[2] * t2[0] +
                taps.weight[3] * t3[0];
    pixel_residual(
        obs, lights,
        [&](const LocalDir& L, const LocalDir& V, T* f) { fiber_reflectance(p, s, L, V, acc, f); },
        r);
    return true;
  }

  static ceres::CostFunction* Create(const Observation* o, const ObsLight* l, const BilinearTaps& t,
                                     FiberAccuracy a) {
    return new ceres::AutoDiffCostFunction<FiberTexelResidual, 3, 3, 3, 1, 1, 1, 1, 1, 1>(
        new FiberTexelResidual(o, l, t, a));
  }

  const Observation* obs;
  const ObsLight* lights;
  BilinearTaps taps;
  FiberAccuracy acc;
};

// psi lives on the circle of period pi (the model is unchanged under T -> -T, MODELS.md §1).
class HalfTurnManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 1; }
  int TangentSize() const override { return 1; }
  bool Plus(const double* x, const double* delta, double* y) const override {
    y[0] = wrap(x[0] + delta[0]);
    return true;
  }
  bool PlusJacobian(const double*, double* j) const override {
    j[0] = 1.0;
    return true;
  }
  bool Minus(const double* y, const double* x, double* d) const override {
    double v = wrap(y[0] - x[0]);
    if (v > M_PI / 2) v -= M_PI;
    d[0] = v;
    return true;
  }
  bool MinusJacobian(const double*, double* j) const override {
    j[0] = 1.0;
    return true;
  }
  static double wrap(double a) { return wrap_half_turn(a); }
};

// ---------------------------------------------------------------------------------------------
// Parameter state.
struct State {
  double kd[3] = {0.1, 0.1, 0.1}, ks[3] = {0.1, 0.1, 0.1};
  double logn = std::log(20.0), psi = 0.0;
  double iso[7] = {0.01, 0.01, 0.01, 0.01, 0.01, 0.01, std::log(20.0)};
  double sec[2] = {M_PI / 2, 0.5};
  double topo[1] = {0.5};      // fiber model: s or the map amplitude A
  std::vector<double> texels;  // fiber model, kTexels: N x N values of s
  double dummy_iso[1] = {0}, dummy_sec[1] = {0};
};

// Up to `count` of n observation indices, spread by the golden-ratio sequence rather than a
// fixed stride: a stride can alias with the layout of the data (10 000 identical views, a
// stride equal to the view size, gave two distinct pixels and psi 131 deg for 30).
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

// At fixed (psi, n[, topology]) the model is linear in k_d and k_s: per channel, the 2x2
// non-negative least-squares problem on the columns cols(o) -> (diffuse, specular) is solved in
// closed form (unconstrained, k_d only, k_s only; best non-negative). Returns the sum of squares.
template <class Cols>
double solve_kd_ks(const ObsSet& os, const std::vector<size_t>& subset, Cols cols, double kd[3],
                   double ks[3]) {
  double dd[3] = {0, 0, 0}, ds[3] = {0, 0, 0}, ss[3] = {0, 0, 0}, dy[3] = {0, 0, 0},
         sy[3] = {0, 0, 0}, yy[3] = {0, 0, 0};
  for (size_t i : subset) {
    const Observation& o = os.obs[i];
    double dcol[3] = {0, 0, 0}, scol[3] = {0, 0, 0};
    cols(o, dcol, scol);
    for (int ch = 0; ch < 3; ++ch) {
      const double y = o.y[ch] - o.base[ch];
      dd[ch] += dcol[ch] * dcol[ch];
      ds[ch] += dcol[ch] * scol[ch];
      ss[ch] += scol[ch] * scol[ch];
      dy[ch] += dcol[ch] * y;
      sy[ch] += scol[ch] * y;
      yy[ch] += y * y;
    }
  }
  double cost = 0;
  for (int ch = 0; ch < 3; ++ch) {
    auto sse = [&](double a, double b) {
      return yy[ch] - 2 * a * dy[ch] - 2 * b * sy[ch] + a * a * dd[ch] + 2 * a * b * ds[ch] +
             b * b * ss[ch];
    };
    double ba = 0, bb = 0, bc = sse(0, 0);
    const double det = dd[ch] * ss[ch] - ds[ch] * ds[ch];
    if (det > 1e-300) {
      const double a = (dy[ch] * ss[ch] - sy[ch] * ds[ch]) / det,
                   b = (sy[ch] * dd[ch] - dy[ch] * ds[ch]) / det;
      if (a >= 0 && b >= 0 && sse(a, b) < bc) ba = a, bb = b, bc = sse(a, b);
    }
    if (dd[ch] > 0) {
      const double a = std::max(dy[ch] / dd[ch], 0.0);
      if (sse(a, 0) < bc) ba = a, bb = 0, bc = sse(a, 0);
    }
    if (ss[ch] > 0) {
      const double b = std::max(sy[ch] / ss[ch], 0.0);
      if (sse(0, b) < bc) ba = 0, bb = b, bc = sse(0, b);
    }
    kd[ch] = ba;
    ks[ch] = bb;
    cost += bc;
  }
  return cost;
}

constexpr size_t kMaxStartObs = 4000;  // the start and stage 1 use at most this many pixels

void set_start_kd_ks(const double kd[3], const double ks[3], State* st) {
  for (int ch = 0; ch < 3; ++ch) {
    // Keep the start strictly inside the bounds so the solver can move both ways.
    st->kd[ch] = std::max(kd[ch], 1e-4);
    st->ks[ch] = std::max(ks[ch], 1e-4);
  }
}

// Start: grid over psi (5 degree steps) and n (powers of 2 from 2 to 4096) with the line model's
// lobe (the fiber model's peaks sit at the same place); k_d, k_s solved at every node.
std::string grid_start(const ObsSet& os, State* st, bool progress = false) {
  Progress bar("fit: start grid (psi x n)", 36, progress);
  const std::vector<size_t> subset = start_subset(os.obs.size(), kMaxStartObs);
  double best = std::numeric_limits<double>::infinity();
  double best_psi = 0, best_logn = 0, best_kd[3] = {0, 0, 0}, best_ks[3] = {0, 0, 0};
  for (int ip = 0; ip < 36; ++ip, bar.advance()) {
    const double psi = ip * M_PI / 36;
    const double c = std::cos(psi), s = std::sin(psi);
    for (int in = 1; in <= 12; ++in) {
      const double n = std::pow(2.0, in);
      double kd[3], ks[3];
      const double cost = solve_kd_ks(
          os, subset,
          [&](const Observation& o, double* dcol, double* scol) {
            const double b = c * o.V.u + s * o.V.w;
            for (uint32_t k = 0; k < o.num_lights; ++k) {
              const ObsLight& l = os.lights[o.first_light + k];
              double D, S;
              line_DS(c * l.L.u + s * l.L.w, b, n, &D, &S);
              for (int ch = 0; ch < 3; ++ch) {
                dcol[ch] += l.E[ch] * l.L.n * D;
                scol[ch] += l.E[ch] * l.L.n * S;
              }
            }
          },
          kd, ks);
      if (cost < best) {
        best = cost;
        best_psi = psi;
        best_logn = std::log(n);
        std::copy(kd, kd + 3, best_kd);
        std::copy(ks, ks + 3, best_ks);
      }
    }
  }
  st->psi = best_psi;
  st->logn = best_logn;
  set_start_kd_ks(best_kd, best_ks, st);
  st->sec[0] = HalfTurnManifold::wrap(best_psi + M_PI / 2);
  char buf[160];
  std::snprintf(buf, sizeof buf, "grid psi=%.1f deg, n=%.0f (36 x 12 nodes on %zu pixels)",
                rad_to_deg(best_psi), std::exp(best_logn), subset.size());
  return buf;
}

// Fiber model start: from the line grid's (psi, n), a grid over the topology (s in 0.05..0.95,
// or A in -1..1) and n around the line value, k_d, k_s solved in closed form at every node.
std::string fiber_grid_start(const ObsSet& os, const FiberAccuracy& acc, State* st, bool progress) {
  std::string line = grid_start(os, st, progress);
  const std::vector<size_t> subset = start_subset(os.obs.size(), kMaxStartObs);
  std::vector<double> topo_values;
  if (os.topology == TopologyMode::kGlobalS || os.topology == TopologyMode::kTexels)
    for (int i = 0; i < 10; ++i) topo_values.push_back(0.05 + 0.1 * i);
  else if (os.topology == TopologyMode::kAmplitude)
    for (int i = 0; i <= 8; ++i) topo_values.push_back(-1.0 + 0.25 * i);
  else
    topo_values.push_back(0.0);
  const double c = std::cos(st->psi), sn = std::sin(st->psi), logn0 = st->logn;
  double best = std::numeric_limits<double>::infinity(), best_t = topo_values[0], best_logn = logn0;
  double best_kd[3], best_ks[3];
  for (double t : topo_values)
    for (double dl : {-0.7, 0.0, 0.7}) {
      const double n = std::exp(logn0 + dl);
      double kd[3], ks[3];
      const double cost = solve_kd_ks(
          os, subset,
          [&](const Observation& o, double* dcol, double* scol) {
            const double s = os.topology == TopologyMode::kAmplitude
                                 ? topology_with_map(o.smath, t, o.mapv)
                             : os.topology == TopologyMode::kMathematical ? o.smath
                                                                          : t;
            const double b = c * o.V.u + sn * o.V.w, vb = c * o.V.w - sn * o.V.u;
            for (uint32_t k = 0; k < o.num_lights; ++k) {
              const ObsLight& l = os.lights[o.first_light + k];
              double D, S;
              fiber_DS(c * l.L.w - sn * l.L.u, l.L.n, vb, o.V.n, c * l.L.u + sn * l.L.w, b, n, s,
                       acc, &D, &S);
              for (int ch = 0; ch < 3; ++ch) {
                dcol[ch] += l.E[ch] * D;
                scol[ch] += l.E[ch] * S;
              }
            }
          },
          kd, ks);
      if (cost < best) {
        best = cost;
        best_t = t;
        best_logn = std::log(n);
        std::copy(kd, kd + 3, best_kd);
        std::copy(ks, ks + 3, best_ks);
      }
    }
  st->topo[0] = best_t;
  if (os.topology == TopologyMode::kTexels)
    st->texels.assign(static_cast<size_t>(os.texels) * os.texels, best_t);
  st->logn = best_logn;
  set_start_kd_ks(best_kd, best_ks, st);
  char buf[200];
  std::snprintf(buf, sizeof buf, "; fiber: topology %s=%.2f, n=%.0f (%zu x 3 nodes)",
                os.topology == TopologyMode::kAmplitude ? "A" : "s", best_t, std::exp(best_logn),
                topo_values.size());
  return line + buf;
}

// Adds one residual block per observation in `idx` (analytic for the plain line model).
template <bool kIso, bool kSecond>
void add_blocks(ceres::Problem* pb, const ObsSet& os, const std::vector<size_t>& idx, State* st,
                ceres::LossFunction* loss) {
  for (size_t i : idx) {
    ceres::CostFunction* cf;
    if constexpr (!kIso && !kSecond)
      cf = new LineResidualAnalytic(&os.obs[i], os.lights.data());
    else
      cf = LineResidual<kIso, kSecond>::Create(&os.obs[i], os.lights.data());
    pb->AddResidualBlock(cf, loss, st->kd, st->ks, &st->logn, &st->psi,
                         kIso ? st->iso : st->dummy_iso, kSecond ? st->sec : st->dummy_sec);
  }
}

// Bounds of k_d, k_s, log n from models/params.h, and psi on its half-turn manifold: the blocks
// every problem here shares.
void set_core_bounds(ceres::Problem* pb, State* st) {
  const ParamSpec& kd = line_param("kd");
  const ParamSpec& ks = line_param("ks");
  const ParamSpec& n = line_param("n");
  for (int k = 0; k < 3; ++k) {
    pb->SetParameterLowerBound(st->kd, k, kd.lo);
    pb->SetParameterUpperBound(st->kd, k, kd.hi);
    pb->SetParameterLowerBound(st->ks, k, ks.lo);
    pb->SetParameterUpperBound(st->ks, k, ks.hi);
  }
  pb->SetParameterLowerBound(&st->logn, 0, std::log(n.lo));
  pb->SetParameterUpperBound(&st->logn, 0, std::log(n.hi));
  pb->SetManifold(&st->psi, new HalfTurnManifold);
}

struct ProblemSetup {
  bool iso = false, second = false;
  bool fiber = false;
  FiberAccuracy acc;
};

std::unique_ptr<ceres::Problem> build_problem(const ObsSet& os, const std::vector<size_t>& idx,
                                              State* st, const ProblemSetup& ps,
                                              ceres::LossFunction* loss) {
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  po.manifold_ownership = ceres::TAKE_OWNERSHIP;
  auto pb = std::make_unique<ceres::Problem>(po);
  if (ps.fiber && os.topology == TopologyMode::kTexels) {
    for (size_t i : idx) {
      const BilinearTaps t = bilinear_wrap(os.obs[i].u, os.obs[i].v, os.texels, os.texels);
      pb->AddResidualBlock(FiberTexelResidual::Create(&os.obs[i], os.lights.data(), t, ps.acc),
                           loss, st->kd, st->ks, &st->logn, &st->psi, &st->texels[t.index[0]],
                           &st->texels[t.index[1]], &st->texels[t.index[2]],
                           &st->texels[t.index[3]]);
    }
    for (double& t : st->texels)
      if (pb->HasParameterBlock(&t)) {
        pb->SetParameterLowerBound(&t, 0, line_param("topology.s").lo);
        pb->SetParameterUpperBound(&t, 0, line_param("topology.s").hi);
      }
  } else if (ps.fiber) {
    for (size_t i : idx)
      pb->AddResidualBlock(FiberResidual::Create(&os.obs[i], os.lights.data(), os.topology, ps.acc),
                           loss, st->kd, st->ks, &st->logn, &st->psi, st->topo);
    if (os.topology == TopologyMode::kGlobalS) {
      pb->SetParameterLowerBound(st->topo, 0, line_param("topology.s").lo);
      pb->SetParameterUpperBound(st->topo, 0, line_param("topology.s").hi);
    } else if (os.topology == TopologyMode::kAmplitude) {
      pb->SetParameterLowerBound(st->topo, 0, line_param("topology.amplitude").lo);
      pb->SetParameterUpperBound(st->topo, 0, line_param("topology.amplitude").hi);
    } else {
      pb->SetParameterBlockConstant(st->topo);
    }
  } else if (ps.iso && ps.second)
    add_blocks<true, true>(pb.get(), os, idx, st, loss);
  else if (ps.iso)
    add_blocks<true, false>(pb.get(), os, idx, st, loss);
  else if (ps.second)
    add_blocks<false, true>(pb.get(), os, idx, st, loss);
  else
    add_blocks<false, false>(pb.get(), os, idx, st, loss);
  set_core_bounds(pb.get(), st);
  if (ps.fiber) return pb;
  if (ps.iso) {
    for (int k = 0; k < 6; ++k) pb->SetParameterLowerBound(st->iso, k, 0.0);
    const ParamSpec& ni = line_param("isotropic.n");
    pb->SetParameterLowerBound(st->iso, 6, std::log(ni.lo));
    pb->SetParameterUpperBound(st->iso, 6, std::log(ni.hi));
  } else {
    pb->SetParameterBlockConstant(st->dummy_iso);
  }
  if (ps.second) {
    pb->SetParameterLowerBound(st->sec, 1, 0.0);
    pb->SetParameterUpperBound(st->sec, 1, 1.0);
  } else {
    pb->SetParameterBlockConstant(st->dummy_sec);
  }
  return pb;
}

// Each solver iteration on the terminal (stderr), overwriting one line; nothing when piped.
class TerminalIterations : public ceres::IterationCallback {
 public:
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    std::fprintf(stderr, "\rfit: iteration %3d, cost %.6g, step %.3g      ", s.iteration, s.cost,
                 s.step_norm);
    std::fflush(stderr);
    return ceres::SOLVER_CONTINUE;
  }
};

ceres::Solver::Options solver_options(const FitOptions& opt) {
  ceres::Solver::Options so;
  static TerminalIterations terminal;  // stateless: one for every solve
  if (opt.progress && ::isatty(2)) so.callbacks.push_back(&terminal);
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // at most 17 parameters
  so.max_num_iterations = opt.max_iterations;
  so.num_threads = std::max(1, opt.threads);
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  return so;
}

double median_abs(std::vector<double> v) {
  if (v.empty()) return 0;
  for (double& x : v) x = std::abs(x);
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Does the model describe the data? The residual RMS of a model that fits is about the noise of
// the images (neighbouring pixels tell it, whatever the model); a systematic misfit makes it
// larger. Without images (tables) the robust sigma of the residuals stands in. Noise-free data
// has no noise to compare with: there a misfit below 1e-4 of the signal counts as a fit.
// Returns the warning to give, or "".
std::string misfit_warning(const ObsSet& os, const FitReport& rep) {
  double signal = 0;
  for (const auto& o : os.obs) signal += std::abs(o.y[0]) + std::abs(o.y[1]) + std::abs(o.y[2]);
  signal /= std::max<double>(1.0, 3.0 * static_cast<double>(os.obs.size()));
  constexpr double kMisfitRatio = 2.0, kNoiseFreeFloor = 1e-4;
  const double noise = os.pixel_noise > 0 ? os.pixel_noise : rep.noise_sigma;
  if (!(rep.rms > kMisfitRatio * std::max(noise, kNoiseFreeFloor * signal))) return "";
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "the model does not describe the data: residual RMS %.3g is %.1fx the noise of "
                "the images %.3g. Likely causes: a second fiber direction (woven cloth: "
                "--fit-second-fiber), an isotropic term (--fit-isotropic), shadows or "
                "interreflections, a wrong exposure or color.encoding, hot pixels. Check "
                "`aniso verify CAPTURE MATERIAL --residuals DIR`.",
                rep.rms, rep.rms / std::max(noise, 1e-300), noise);
  return buf;
}

FitResult solve(const ObsSet& os, const FitOptions& opt, FitReport rep, const RGB& ka) {
  const bool fiber = opt.model == "fiber";
  if (!fiber && opt.model != "line")
    throw Error("fit: --model must be line, fiber or auto (got '" + opt.model + "')");
  if (fiber && (opt.fit_isotropic || opt.fit_second))
    throw Error("fit: --fit-isotropic and --fit-second-fiber are available with --model line only");
  if (os.obs.empty())
    throw Error(
        "fit: no usable observations (empty mask, all pixels saturated, non-finite or unlit)");
  const bool fit_topo = fiber && os.topology != TopologyMode::kMathematical;
  const bool texels = fiber && os.topology == TopologyMode::kTexels;
  if (os.topology == TopologyMode::kTexels && !fiber)
    throw Error("fit: --topology-map fits the fiber model's topology: use it with --model fiber");
  const size_t ntopo = texels ? static_cast<size_t>(os.texels) * os.texels : (fit_topo ? 1 : 0);
  const size_t nparam = 8 + (opt.fit_isotropic ? 7 : 0) + (opt.fit_second ? 2 : 0) + ntopo;
  if (os.obs.size() * (os.grey ? 1 : 3) <= nparam)
    throw Error("fit: " + std::to_string(os.obs.size()) + " observations cannot determine " +
                std::to_string(nparam) + " parameters");
  FitResult res;
  const auto t_start = Clock::now();
  State st;
  FiberAccuracy acc;
  acc.order = opt.fiber_order;
  rep.start =
      fiber ? fiber_grid_start(os, acc, &st, opt.progress) : grid_start(os, &st, opt.progress);
  const ProblemSetup ps{opt.fit_isotropic, opt.fit_second, fiber, acc};

  // Stage 1: plain least squares on the start subset to settle near the optimum and measure noise.
  std::vector<size_t> sub, all(os.obs.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  constexpr size_t kStage1Obs = 4000;
  sub = start_subset(os.obs.size(), kStage1Obs);
  {
    auto pb = build_problem(os, sub, &st, ps, nullptr);
    ceres::Solver::Summary s1;
    ceres::Solve(solver_options(opt), pb.get(), &s1);
    std::vector<double> r;
    pb->Evaluate(ceres::Problem::EvaluateOptions(), nullptr, &r, nullptr, nullptr);
    rep.noise_sigma = 1.4826 * median_abs(r);  // robust sigma (MAD) of the residuals
  }
  rep.seconds_start = since(t_start);

  // Stage 2: all observations with the robust loss, scaled to 3 robust sigmas (outliers beyond
  // it, e.g. specks or unmodelled glints, count linearly instead of quadratically). A floor keeps
  // the scale meaningful on noise-free data.
  const auto t_solve = Clock::now();
  constexpr double kLossScaleFloor = 1e-6;
  rep.loss_scale = std::max(3.0 * rep.noise_sigma, kLossScaleFloor);
  ceres::LossFunction* loss = nullptr;
  if (opt.loss == "huber")
    loss = new ceres::HuberLoss(rep.loss_scale);
  else if (opt.loss == "cauchy")
    loss = new ceres::CauchyLoss(rep.loss_scale);
  else if (opt.loss != "none")
    throw Error("fit: --loss must be huber, cauchy or none (got '" + opt.loss + "')");
  rep.loss = loss ? opt.loss + "(" + std::to_string(rep.loss_scale) + ")" : "none";
  std::unique_ptr<ceres::Problem> pb;
  ceres::Solver::Summary sum;
  double rss = 0;
  std::vector<double> sqrt_w;  // IRLS weights of the chunked path (must outlive pb)
  const bool chunked = !fiber && !opt.fit_isotropic && !opt.fit_second && opt.chunked;
  if (chunked) {
    // Robust loss by iteratively reweighted least squares: per pixel w = rho'(|r|^2) of the
    // loss Ceres would apply, re-solved until the weights settle (at most kIrlsRounds).
    constexpr int kIrlsRounds = 6;
    constexpr double kWeightsSettled = 1e-3;
    constexpr size_t kChunk = 256;
    sqrt_w.assign(os.obs.size(), 1.0);
    std::vector<double> w_prev(os.obs.size(), 1.0);
    for (int round = 0; round < kIrlsRounds; ++round) {
      ceres::Problem::Options po;
      po.manifold_ownership = ceres::TAKE_OWNERSHIP;
      pb = std::make_unique<ceres::Problem>(po);
      for (size_t c0 = 0; c0 < os.obs.size(); c0 += kChunk) {
        std::vector<const Observation*> chunk;
        for (size_t i = c0; i < std::min(os.obs.size(), c0 + kChunk); ++i)
          chunk.push_back(&os.obs[i]);
        pb->AddResidualBlock(new LineChunkResidual(std::move(chunk), os.lights.data(), &sqrt_w, c0),
                             nullptr, st.kd, st.ks, &st.logn, &st.psi);
      }
      set_core_bounds(pb.get(), &st);
      ceres::Solver::Summary round_sum;
      ceres::Solve(solver_options(opt), pb.get(), &round_sum);
      sum.iterations.insert(sum.iterations.end(), round_sum.iterations.begin() + (round ? 1 : 0),
                            round_sum.iterations.end());
      sum.num_residual_evaluations += round_sum.num_residual_evaluations;
      sum.num_jacobian_evaluations += round_sum.num_jacobian_evaluations;
      sum.termination_type = round_sum.termination_type;
      sum.message = round_sum.message;
      if (!loss) break;
      // New weights from the unweighted residuals.
      double change = 0;
      for (size_t i = 0; i < os.obs.size(); ++i) {
        const LineResidualAnalytic one(&os.obs[i], os.lights.data());
        const double dummy = 0;
        const double* params[6] = {st.kd, st.ks, &st.logn, &st.psi, &dummy, &dummy};
        double ri[3];
        one.Evaluate(params, ri, nullptr);
        const double s2 = ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2];
        double rho[3];
        loss->Evaluate(s2, rho);
        change = std::max(change, std::abs(rho[1] - w_prev[i]));
        w_prev[i] = rho[1];
        sqrt_w[i] = std::sqrt(std::max(rho[1], 0.0));
      }
      if (change < kWeightsSettled) break;
    }
    delete loss;
    loss = nullptr;
  } else {
    pb = build_problem(os, all, &st, ps, loss);
    ceres::Solve(solver_options(opt), pb.get(), &sum);
  }
  if (opt.progress && ::isatty(2)) std::fprintf(stderr, "\r%70s\r", "");  // the iteration line
  rep.iterations = static_cast<int>(sum.iterations.size()) - 1;
  rep.termination = ceres::TerminationTypeToString(sum.termination_type);
  rep.residual_evaluations = sum.num_residual_evaluations;
  rep.jacobian_evaluations = sum.num_jacobian_evaluations;
  if (sum.termination_type == ceres::FAILURE) throw Error("fit: the solver failed: " + sum.message);
  std::vector<double> r;
  pb->Evaluate(ceres::Problem::EvaluateOptions(), nullptr, &r, nullptr, nullptr);
  for (double x : r) rss += x * x;
  const double m = static_cast<double>(os.obs.size()) * (os.grey ? 1 : 3);
  rep.rms = std::sqrt(rss / (os.grey ? 3 * m : m));
  rep.rss = rss / (os.grey ? 3 : 1);
  rep.parameters = nparam;
  // Bayesian information criterion for Gaussian residuals (model selection, --model auto).
  rep.bic = m * std::log(std::max(rep.rss, 1e-300) / m) + static_cast<double>(nparam) * std::log(m);
  rep.pixel_noise = os.pixel_noise;
  if (auto w = misfit_warning(os, rep); !w.empty()) rep.warnings.push_back(w);
  rep.seconds_solve = since(t_solve);

  // Result.
  Material& mat = res.material;
  mat.model = fiber ? Model::kFiber : Model::kLine;
  if (fiber) {
    switch (os.topology) {
      case TopologyMode::kGlobalS:
        mat.topology = UniformS{st.topo[0]};
        break;
      case TopologyMode::kAmplitude:
        mat.topology = TopologyMapRef{os.topology_map, st.topo[0], os.topology_mathematical};
        break;
      case TopologyMode::kMathematical:
        mat.topology = MathematicalS{os.topology_mathematical};
        break;
      case TopologyMode::kTexels:
        mat.topology = SMapRef{};  // the file is named when the material is written
        res.s_texels_n = os.texels;
        break;
    }
    if (!fit_topo)
      res.fixed["topology"] =
          "taken from the capture's mathematical topology buffer (no map to fit)";
  }
  for (int k = 0; k < 3; ++k) {
    mat.kd[k] = st.kd[k];
    mat.ks[k] = st.ks[k];
  }
  mat.ka = ka;
  mat.n = std::exp(st.logn);
  mat.fiber_angle_deg = wrap_fiber_deg(rad_to_deg(st.psi));
  if (opt.fit_isotropic) {
    mat.has_isotropic = true;
    for (int k = 0; k < 3; ++k) {
      mat.iso_kd[k] = st.iso[k];
      mat.iso_ks[k] = st.iso[3 + k];
    }
    mat.iso_n = std::exp(st.iso[6]);
  } else {
    res.fixed["isotropic"] = "not fitted (absent; pass --fit-isotropic to fit it)";
  }
  if (opt.fit_second) {
    mat.has_second_fiber = true;
    mat.second_angle_deg = wrap_fiber_deg(rad_to_deg(st.sec[0]));
    mat.second_weight = st.sec[1];
  } else {
    res.fixed["second_fiber"] = "not fitted (absent; pass --fit-second-fiber to fit it)";
  }
  res.fixed["ka"] = "not fitted: taken as given (the capture's ambient multiplies it)";

  // Identifiability (MODELS.md §6). k_s -> 0 leaves n undetermined: hold log n constant so the
  // covariance of the rest stays meaningful, and report n as undetermined rather than confident.
  const auto t_cov = Clock::now();
  const double ks_max = std::max({mat.ks[0], mat.ks[1], mat.ks[2]});
  const double kd_max = std::max({mat.kd[0], mat.kd[1], mat.kd[2]});
  // Below this fraction of the diffuse level (or absolute 1e-4) the lobe carries no usable signal.
  constexpr double kKsNegligible = 1e-4;
  const bool n_free = ks_max > kKsNegligible * std::max(1.0, kd_max);
  if (!n_free) {
    res.undetermined["n"] =
        "k_s is about 0 (" + std::to_string(ks_max) + "): no specular lobe to measure n from";
    pb->SetParameterBlockConstant(&st.logn);
  }
  // The same for the optional terms: an isotropic lobe of zero weight leaves n_iso free, a
  // second fiber of zero weight (w -> 1) leaves its angle free. Hold the free coordinate fixed
  // (a subset manifold), name it, and keep everyone else's sigma.
  bool iso_n_free = true, sec_angle_free = true;
  if (opt.fit_isotropic) {
    const double iso_ks = std::max({st.iso[3], st.iso[4], st.iso[5]});
    if (!(iso_ks > kKsNegligible * std::max(1.0, kd_max))) {
      iso_n_free = false;
      res.undetermined["isotropic.n"] =
          "the isotropic specular k_s,iso is about 0 (" + std::to_string(iso_ks) +
          "): no isotropic lobe to measure n_iso from (the data show no isotropic term)";
      pb->SetManifold(st.iso, new ceres::SubsetManifold(7, {6}));
    }
  }
  if (opt.fit_second) {
    constexpr double kWeightNegligible = 1e-4;  // of the second lobe: 1 - w
    if (!(1.0 - st.sec[1] > kWeightNegligible)) {
      sec_angle_free = false;
      res.undetermined["second_fiber.angle_deg"] =
          "the second fiber's weight 1 - w is about 0: no second lobe to measure its angle from";
      pb->SetManifold(st.sec, new ceres::SubsetManifold(2, {0}));
    }
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = 0;  // rank deficiency must fail, never produce a zero variance
  co.min_reciprocal_condition_number = 1e-14;
  co.num_threads = std::max(1, opt.threads);
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks = {
      {st.kd, st.kd}, {st.ks, st.ks}, {&st.psi, &st.psi}};
  if (n_free) blocks.push_back({&st.logn, &st.logn});
  if (fit_topo && !texels) blocks.push_back({st.topo, st.topo});
  if (texels)
    for (double& t : st.texels)
      if (pb->HasParameterBlock(&t)) blocks.push_back({&t, &t});
  if (opt.fit_isotropic) blocks.push_back({st.iso, st.iso});
  if (opt.fit_second) blocks.push_back({st.sec, st.sec});
  // sigma^2 from the residuals (unweighted least squares); a grey table counts each value once.
  const double dof = std::max(1.0, m - static_cast<double>(nparam));
  double s2 = rss / (os.grey ? 3 : 1) / dof;
  if (os.grey) s2 *= 3;  // its three identical channels must not count as three measurements
  // Every pair of blocks (for the correlation matrix), except with per-texel maps (N^2 blocks).
  std::vector<const double*> block_list;
  for (const auto& b : blocks) block_list.push_back(b.first);
  const bool computed = texels ? cov.Compute(blocks, pb.get()) : cov.Compute(block_list, pb.get());
  if (computed) {
    // The full correlation matrix of the fitted numbers (not the per-texel maps), in the
    // coordinates the solver uses (log n, psi in radians): how the parameters trade off.
    if (!texels) {
      std::vector<const double*> cb;
      std::vector<std::string>& names = res.correlation_names;
      auto add = [&](const double* b, std::initializer_list<const char*> ns) {
        if (!pb->HasParameterBlock(const_cast<double*>(b)) ||
            pb->IsParameterBlockConstant(const_cast<double*>(b)))
          return;
        cb.push_back(b);
        for (const char* n : ns) names.push_back(n);
      };
      add(st.kd, {"kd.r", "kd.g", "kd.b"});
      add(st.ks, {"ks.r", "ks.g", "ks.b"});
      add(&st.psi, {"fiber_angle"});
      if (n_free) add(&st.logn, {"log n"});
      if (fit_topo)
        add(st.topo, {os.topology == TopologyMode::kGlobalS ? "topology.s" : "topology.amplitude"});
      if (opt.fit_isotropic)
        add(st.iso, {"isotropic.kd.r", "isotropic.kd.g", "isotropic.kd.b", "isotropic.ks.r",
                     "isotropic.ks.g", "isotropic.ks.b", "isotropic.log n"});
      if (opt.fit_second) add(st.sec, {"second_fiber.angle", "second_fiber.weight"});
      const size_t k = names.size();
      std::vector<double> c(k * k, 0.0);
      // Tangent-space size differs from the ambient size for the subset manifolds: ask in the
      // ambient space and leave held coordinates at 0 correlation.
      if (!cb.empty() && cov.GetCovarianceMatrix(cb, c.data())) {
        res.correlation.assign(k, std::vector<double>(k, 0.0));
        for (size_t i = 0; i < k; ++i)
          for (size_t j = 0; j < k; ++j) {
            const double d = std::sqrt(c[i * k + i] * c[j * k + j]);
            res.correlation[i][j] = d > 0 && std::isfinite(d) ? c[i * k + j] / d : (i == j);
          }
      } else {
        names.clear();
      }
    }
    auto diag = [&](const double* b, int size) {
      std::vector<double> c(size * size);
      cov.GetCovarianceBlock(b, b, c.data());
      std::vector<double> d(size);
      for (int i = 0; i < size; ++i) d[i] = std::sqrt(std::max(c[i * size + i], 0.0) * s2);
      return d;
    };
    res.sigma["kd"] = diag(st.kd, 3);
    res.sigma["ks"] = diag(st.ks, 3);
    const double spsi = rad_to_deg(diag(&st.psi, 1)[0]);
    // A fiber angle this uncertain says nothing: a lone light along T (s_L -> 0) or no lobe.
    constexpr double kPsiUndeterminedDeg = 10.0;
    if (spsi > kPsiUndeterminedDeg)
      res.undetermined["fiber_angle_deg"] =
          "sigma " + std::to_string(spsi) + " deg: the data barely constrain psi";
    else
      res.sigma["fiber_angle_deg"] = {spsi};
    if (n_free) {
      const double sl = diag(&st.logn, 1)[0];
      constexpr double kLogNUndetermined = 1.0;  // a factor e either way: n is not known
      if (sl > kLogNUndetermined)
        res.undetermined["n"] =
            "sigma of log n is " + std::to_string(sl) + ": the lobe is barely measured";
      else
        res.sigma["n"] = {mat.n * sl};
    }
    if (texels) {
      res.s_texels = st.texels;
      res.s_texel_sigma.assign(st.texels.size(), -1.0);
      size_t undetermined = 0;
      for (size_t i = 0; i < st.texels.size(); ++i) {
        if (!pb->HasParameterBlock(&st.texels[i])) {
          ++undetermined;
          continue;
        }
        const double sd = diag(&st.texels[i], 1)[0];
        constexpr double kTexelUndetermined = 0.25;  // as for one global s
        if (std::isfinite(sd) && sd <= kTexelUndetermined)
          res.s_texel_sigma[i] = sd;
        else
          ++undetermined;
      }
      if (undetermined)
        res.undetermined["topology.s_map"] =
            std::to_string(undetermined) + " of " + std::to_string(st.texels.size()) +
            " texels are not determined (no pixel covers them, or too few do); their "
            "sigma is written as -1";
    } else if (fit_topo) {
      const double sd = diag(st.topo, 1)[0];
      const std::string key =
          os.topology == TopologyMode::kGlobalS ? "topology.s" : "topology.amplitude";
      // A topology this uncertain is not measured: flat-looking data, or s near the s = 0 = 1 seam.
      constexpr double kTopologyUndetermined = 0.25;
      if (sd > kTopologyUndetermined)
        res.undetermined[key] =
            "sigma " + std::to_string(sd) + ": the data barely constrain the topology";
      else
        res.sigma[key] = {sd};
    }
    if (opt.fit_isotropic) {
      const auto d = diag(st.iso, 7);
      res.sigma["isotropic.kd"] = {d[0], d[1], d[2]};
      res.sigma["isotropic.ks"] = {d[3], d[4], d[5]};
      if (iso_n_free) res.sigma["isotropic.n"] = {mat.iso_n * d[6]};
    }
    if (opt.fit_second) {
      const auto d = diag(st.sec, 2);
      if (sec_angle_free) res.sigma["second_fiber.angle_deg"] = {rad_to_deg(d[0])};
      res.sigma["second_fiber.weight"] = {d[1]};
    }
  } else {
    res.undetermined["covariance"] =
        "rank deficient: some combination of parameters is not determined by these observations; "
        "no uncertainty "
        "is reported rather than a false one";
  }
  // A variance that is not a finite number (0 * inf on data without signal) is no uncertainty:
  // the parameter is reported as undetermined instead.
  for (auto it = res.sigma.begin(); it != res.sigma.end();) {
    bool ok = true;
    for (double v : it->second) ok &= std::isfinite(v);
    if (ok) {
      ++it;
      continue;
    }
    res.undetermined[it->first] =
        "its variance is not finite: the data carry no information about it";
    it = res.sigma.erase(it);
  }
  rep.seconds_covariance = since(t_cov);
  rep.seconds += since(t_start);
  res.report = rep;
  return res;
}

void add_pixel_observations(const ViewData& d, const ViewSpec& v, const CaptureSet& set,
                            const Material& known, int stride, ObsSet* os, FitReport* rep) {
  const int w = d.rgb.width, h = d.rgb.height;
  for (int y = 0; y < h; y += stride)
    for (int x = 0; x < w; x += stride) {
      if (!d.use[static_cast<size_t>(y) * w + x]) continue;
      SurfacePoint sp;
      if (!frame_at(d.P, d.N, d.U, x, y, &sp)) {
        ++rep->nonfinite;
        continue;
      }
      Observation o;
      o.V = to_local(sp, normalize(d.eye - sp.P));
      o.first_light = static_cast<uint32_t>(os->lights.size());
      for (const Light& l : v.lights) {
        Vec3 L;
        RGB E;
        double dist;
        if (!light_at(l, sp.P, &L, &E, &dist)) continue;
        ObsLight ol;
        ol.L = to_local(sp, L);
        if (!(ol.L.n > 0.0)) continue;
        for (int k = 0; k < 3; ++k) ol.E[k] = v.exposure * E[k];
        os->lights.push_back(ol);
      }
      o.num_lights = static_cast<uint32_t>(os->lights.size()) - o.first_light;
      for (int k = 0; k < 3; ++k) {
        o.y[k] = d.rgb.at(x, y, k);
        o.base[k] = v.exposure * known.ka[k] * set.ambient[k];
      }
      o.smath = d.smath.at(x, y, 0);
      o.mapv = d.mapv.at(x, y, 0);
      if (!d.uv.empty()) {
        o.u = d.uv.at(x, y, 0);
        o.v = d.uv.at(x, y, 1);
      }
      if (o.num_lights == 0) {
        ++rep->unlit;  // no light reaches it: it constrains nothing that is fitted
        continue;
      }
      os->obs.push_back(o);
    }
}

// Values far above anything else in the set (hot pixels, a broken writer's 1e30) would steer the
// closed-form start and the noise estimate before any robust loss can act: a pixel with a value
// above kImplausible times the 90th percentile of all values is left out and counted (a real
// highlight is brighter than most pixels, but not 10^4 times brighter than the brightest tenth).
void drop_implausible(ObsSet* os, FitReport* rep) {
  if (os->obs.size() < 100) return;
  std::vector<double> mags;
  mags.reserve(os->obs.size());
  for (const auto& o : os->obs)
    mags.push_back(std::max({std::abs(o.y[0]), std::abs(o.y[1]), std::abs(o.y[2])}));
  std::nth_element(mags.begin(), mags.begin() + mags.size() * 9 / 10, mags.end());
  const double p90 = mags[mags.size() * 9 / 10];
  constexpr double kImplausible = 1e4;
  const double limit = kImplausible * std::max(p90, 1e-12);
  size_t kept = 0;
  for (const auto& o : os->obs)
    if (std::max({std::abs(o.y[0]), std::abs(o.y[1]), std::abs(o.y[2])}) <= limit)
      os->obs[kept++] = o;
  rep->implausible += os->obs.size() - kept;
  os->obs.resize(kept);
}

// --model auto fits both models and keeps the one with the lower BIC; otherwise the one asked.
// Ceres logs through glog to stderr; what it says is reported as our own messages instead
// (undetermined parameters, termination), so its raw lines never reach a user's terminal.
void quiet_library_logs() {
  static const bool once = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    FLAGS_stderrthreshold = google::GLOG_FATAL;
    return true;
  }();
  (void)once;
}

FitResult solve_model(const ObsSet& os, const FitOptions& opt, const FitReport& rep,
                      const RGB& ka) {
  quiet_library_logs();
  if (opt.model != "auto") return solve(os, opt, rep, ka);
  FitOptions line = opt, fiber = opt;
  line.model = "line";
  fiber.model = "fiber";
  const bool tty = opt.progress && ::isatty(2);
  if (tty) std::fprintf(stderr, "fit: --model auto: 1/2 the line model\n");
  FitResult rl = solve(os, line, rep, ka);
  if (tty) std::fprintf(stderr, "\nfit: --model auto: 2/2 the fiber model (the slow half)\n");
  FitResult rf = solve(os, fiber, rep, ka);
  if (tty) std::fprintf(stderr, "\n");
  const bool pick_fiber = rf.report.bic < rl.report.bic;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "BIC = m ln(RSS/m) + k ln m over m = %zu values: line %.1f (RSS %.4g, k = %zu), "
                "fiber %.1f (RSS %.4g, "
                "k = %zu); chose %s (lower by %.1f)",
                rl.report.observations, rl.report.bic, rl.report.rss, rl.report.parameters,
                rf.report.bic, rf.report.rss, rf.report.parameters, pick_fiber ? "fiber" : "line",
                std::abs(rf.report.bic - rl.report.bic));
  FitResult& r = pick_fiber ? rf : rl;
  r.report.model_selection = buf;
  for (const FitResult* x : {&rl, &rf}) {
    std::snprintf(buf, sizeof buf,
                  "%-5s residual RMS %.4g, BIC %.1f, %d iterations, %s, solve %.3f s",
                  model_name(x->material.model), x->report.rms, x->report.bic, x->report.iterations,
                  x->report.termination.c_str(), x->report.seconds_solve);
    r.report.model_summaries.push_back(buf);
  }
  r.report.seconds_solve = rl.report.seconds_solve + rf.report.seconds_solve;
  return r;
}

}  // namespace

namespace {
ObsSet load_observations(const CaptureSet& set, const FitOptions& opt, FitReport* rep);
}  // namespace

size_t export_observations(const CaptureSet& set, const FitOptions& opt, const std::string& path,
                           std::vector<double>* start) {
  FitReport rep;
  const ObsSet os = load_observations(set, opt, &rep);
  std::vector<double> rows;
  rows.reserve(os.obs.size() * 14);
  size_t n = 0;
  for (const Observation& o : os.obs) {
    if (o.num_lights != 1) continue;  // the benchmark scripts model one light per view
    const ObsLight& l = os.lights[o.first_light];
    const double r[14] = {o.V.u,  o.V.w,  o.V.n,  l.L.u,  l.L.w,  l.L.n,   l.E[0],
                          l.E[1], l.E[2], o.y[0], o.y[1], o.y[2], o.smath, o.mapv};
    rows.insert(rows.end(), r, r + 14);
    ++n;
  }
  write_atomically(path, [&](const std::string& tmp) {
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw Error(path + ": cannot open for writing");
    const size_t w = std::fwrite(rows.data(), sizeof(double), rows.size(), f);
    std::fclose(f);
    if (w != rows.size()) throw Error(path + ": write failed");
  });
  State st;
  grid_start(os, &st);
  *start = {st.kd[0], st.kd[1], st.kd[2], st.ks[0], st.ks[1], st.ks[2], st.logn, st.psi};
  return n;
}

namespace {

ObsSet load_observations(const CaptureSet& set, const FitOptions& opt, FitReport* rep_out) {
  if (opt.subsample < 1) throw Error("fit: --subsample must be at least 1");
  ObsSet os;
  FitReport& rep = *rep_out;
  rep.views = set.views.size();
  const Material known;  // k_a = 0 unless given: the ambient term is not fitted
  // Fiber model topology: a map in the set means its amplitude is fitted over the per-pixel
  // mathematical topology (0 where no buffer); a topology buffer alone fixes s; else one s.
  TopologyMap map;
  const bool has_map = !set.topology_map.empty();
  if (has_map) {
    map = load_topology_map(join_path(set.dir, set.topology_map));
    os.topology = TopologyMode::kAmplitude;
    os.topology_map = join_path(set.dir, set.topology_map);  // made relative on writing
  }
  bool has_buffer = false;
  for (const auto& v : set.views) has_buffer |= !v.geometry.topology.empty();
  if (has_buffer) {
    // The kind of mathematical topology, when the writer recorded it (capture_sim does); "torus"
    // otherwise (FORMAT.md's name for a per-pixel mathematical topology).
    os.topology_mathematical = MathTopology::kTorus;
    if (!set.provenance.empty()) {
      const auto g = jsonu::json::parse(set.provenance, nullptr, false);
      if (g.is_object() && g.contains("mathematical_topology") &&
          g["mathematical_topology"] == "sphere")
        os.topology_mathematical = MathTopology::kSphere;
    }
  }
  if (has_buffer && !has_map) os.topology = TopologyMode::kMathematical;
  if (opt.topology_texels > 0) {
    if (opt.topology_texels < 2 || opt.topology_texels > 256)
      throw Error("fit: --topology-map N needs N in [2, 256]");
    if (has_map || has_buffer)
      throw Error(
          set.file +
          ": --topology-map fits s per texel, but this set has a topology map or buffer (its "
          "amplitude is what can be fitted: leave --topology-map out)");
    for (const auto& v : set.views)
      if (v.geometry.uv.empty())
        throw Error(set.file + ": --topology-map needs the \"uv\" buffer in every view's geometry");
    os.topology = TopologyMode::kTexels;
    os.texels = opt.topology_texels;
  }
  Progress bar("fit: loading views", set.views.size(), opt.progress);
  size_t grey_views = 0;
  std::vector<double> neighbour_diffs;
  for (size_t i = 0; i < set.views.size(); ++i) {
    const ViewData d = load_view(set, i, has_map ? &map : nullptr);
    grey_views += d.channels == 1;
    // Second differences of three horizontal neighbours (a - 2b + c cancels the shading's
    // gradient) on every 4th row: enough for a median, little time. Zeros are clipped values.
    for (int y = 0; y < d.rgb.height; y += 4)
      for (int x = 0; x + 2 < d.rgb.width; ++x) {
        const size_t p = static_cast<size_t>(y) * d.rgb.width + x;
        if (d.use[p] && d.use[p + 1] && d.use[p + 2])
          for (int c = 0; c < d.channels; ++c) {
            const float a = d.rgb.px[3 * p + c], b = d.rgb.px[3 * (p + 1) + c],
                        e = d.rgb.px[3 * (p + 2) + c];
            if (a > 0 && b > 0 && e > 0) neighbour_diffs.push_back(a - 2 * b + e);
          }
      }
    rep.masked_out += static_cast<size_t>(d.rgb.width) * d.rgb.height - d.mask_pixels;
    rep.saturated += d.saturated;
    rep.nonfinite += d.nonfinite;
    add_pixel_observations(d, set.views[i], set, known, opt.subsample, &os, &rep);
    bar.advance();
  }
  drop_implausible(&os, &rep);
  // sigma of one pixel: the robust sigma of a - 2b + c, over sqrt(1 + 4 + 1).
  if (!neighbour_diffs.empty())
    os.pixel_noise = 1.4826 * median_abs(neighbour_diffs) / std::sqrt(6.0);
  // Grey images: the three channels repeat one measurement, counted once (as for grey tables).
  os.grey = grey_views == set.views.size();
  rep.pixels = os.obs.size();
  rep.observations = os.obs.size() * (os.grey ? 1 : 3);
  return os;
}

}  // namespace

FitResult fit_capture(const CaptureSet& set, const FitOptions& opt) {
  const auto t0 = Clock::now();
  FitReport rep;
  const ObsSet os = load_observations(set, opt, &rep);
  rep.seconds_load = since(t0);
  FitResult r = solve_model(os, opt, rep, {0, 0, 0});
  r.report.seconds = since(t0);
  return r;
}

FitResult fit_table(const SampleTable& t, const FitOptions& opt) {
  if (t.values == SampleTable::Values::kNone)
    throw Error("fit: the sample table has no value columns (r,g,b or y)");
  const auto t0 = Clock::now();
  ObsSet os;
  os.grey = t.values == SampleTable::Values::kGrey;
  FitReport rep;
  for (const auto& row : t.rows) {
    Observation o;
    o.V = dir_from_angles(row.theta_o, row.phi_o);
    ObsLight l;
    l.L = dir_from_angles(row.theta_i, row.phi_i);
    l.E[0] = l.E[1] = l.E[2] = 1.0;
    for (int k = 0; k < 3; ++k) {
      o.y[k] = row.value[k];
      o.base[k] = 0.0;
    }
    if (!(l.L.n > 0.0)) {
      ++rep.unlit;
      continue;
    }
    o.first_light = static_cast<uint32_t>(os.lights.size());
    o.num_lights = 1;
    o.smath = row.s;
    os.lights.push_back(l);
    os.obs.push_back(o);
  }
  // A table with an s column gives the fiber model's topology per row; otherwise one s is fitted.
  if (t.has_s) os.topology = TopologyMode::kMathematical;
  rep.pixels = os.obs.size();
  rep.observations = os.obs.size() * (os.grey ? 1 : 3);
  FitResult r = solve_model(os, opt, rep, {0, 0, 0});
  r.report.seconds = since(t0);
  return r;
}

}  // namespace aniso
