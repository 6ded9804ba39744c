#include "capture_sim/microgeometry.h"

#include <embree3/rtcore.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/progress.h"
#include "geometry/embree_device.h"
#include "io/files/files.h"
#include "models/fiber_model.h"

namespace aniso {

struct MicroPatch::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  double P = 4, H = 0;
  std::vector<std::array<double, 2>> centers;  // (y, z) of each fiber
  int segments_per_fiber = 1;                  // primitive id / this = fiber
};

MicroPatch::MicroPatch(double s, int copies, double length) : impl_(std::make_unique<Impl>()) {
  if (!(s >= 0 && s <= 1)) throw Error("microgeometry: topology s must be in [0, 1]");
  const double theta = kMaxClimbRad * s;
  impl_->P = 4 * std::cos(theta);
  impl_->H = 2 * std::sin(theta);
  impl_->device = new_embree_device("microgeometry");
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
  // Embree's curve intersector is accurate for segments a few radii long (it is built for hair):
  // one 4000-long segment put hits 0.2 off the surface, so each fiber is a chain of short ones.
  constexpr double kSegment = 2.0;
  const int segs = std::max(1, static_cast<int>(std::ceil(length / kSegment)));
  const int fibers = 2 * (2 * copies + 1);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
                                                        RTC_FORMAT_FLOAT4, 4 * sizeof(float),
                                                        static_cast<size_t>(fibers) * (segs + 1)));
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0,
                                                             RTC_FORMAT_UINT, sizeof(unsigned),
                                                             static_cast<size_t>(fibers) * segs));
  if (!v || !idx) throw Error("microgeometry: cannot allocate Embree buffers");
  int f = 0;
  for (int k = -copies; k <= copies; ++k)
    for (int row = 0; row < 2; ++row) {
      const double y = k * impl_->P + (row ? impl_->P / 2 : 0.0), z = row ? impl_->H : 0.0;
      impl_->centers.push_back({y, z});
      for (int e = 0; e <= segs; ++e) {
        float* p = v + 4 * (static_cast<size_t>(f) * (segs + 1) + e);
        p[0] = static_cast<float>(-length / 2 + length * e / segs);
        p[1] = static_cast<float>(y);
        p[2] = static_cast<float>(z);
        p[3] = 1.0f;  // unit radius
      }
      for (int e = 0; e < segs; ++e)
        idx[static_cast<size_t>(f) * segs + e] = static_cast<unsigned>(f * (segs + 1) + e);
      ++f;
    }
  impl_->segments_per_fiber = segs;
  rtcCommitGeometry(g);
  rtcAttachGeometry(impl_->scene, g);
  rtcReleaseGeometry(g);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE)
    throw Error("microgeometry: Embree scene build failed");
}

MicroPatch::~MicroPatch() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

MicroMeasurement MicroPatch::measure(const LocalDir& L, const LocalDir& V, double n, int rays,
                                     uint64_t seed) const {
  MicroMeasurement m;
  if (!(L.n > 0) || !(V.n > 0) || rays < 1) return m;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double P = impl_->P, H = impl_->H;
  // Rays start on the plane z = top, over x in [-1, 1] and y over `periods` whole periods
  // (stratified in y), and travel along -V.
  constexpr int kPeriods = 4;
  const double top = H + 1.0 + 1e-3;
  const double LdotV = L.u * V.u + L.w * V.w + L.n * V.n;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  double sd = 0, sd2 = 0, ss = 0, ss2 = 0;
  size_t hits = 0;
  for (int i = 0; i < rays; ++i) {
    const double y0 = (i + u01(rng)) / rays * kPeriods * P, x0 = 2 * u01(rng) - 1;
    // Start far enough back along V that the origin is above every fiber.
    const double back = 10.0;
    RTCRayHit rh;
    rh.ray.org_x = static_cast<float>(x0 + back * V.u);
    rh.ray.org_y = static_cast<float>(y0 + back * V.w);
    rh.ray.org_z = static_cast<float>(top + back * V.n);
    rh.ray.dir_x = static_cast<float>(-V.u);
    rh.ray.dir_y = static_cast<float>(-V.w);
    rh.ray.dir_z = static_cast<float>(-V.n);
    rh.ray.tnear = 0.f;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.time = 0.f;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &ctx, &rh);
    ++m.rays;
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
      continue;  // through a gap (cannot happen for a full row)
    const auto& c = impl_->centers[rh.hit.primID / impl_->segments_per_fiber];
    const double t = rh.ray.tfar;
    const double px = rh.ray.org_x - t * V.u, py = rh.ray.org_y - t * V.w,
                 pz = rh.ray.org_z - t * V.n;
    double ny = py - c[0], nz = pz - c[1];
    const double nl = std::hypot(ny, nz);
    ny /= nl;
    nz /= nl;
    ++hits;
    const double cosL = ny * L.w + nz * L.n;  // n = (0, ny, nz) in (T, B, N)
    if (cosL <= 0) continue;  // facing away from the light: contributes 0 to both means
    RTCRay sr;
    constexpr double kOffset = 1e-3;  // off the surface, above float precision at |y| ~ 10
    sr.org_x = static_cast<float>(px);
    sr.org_y = static_cast<float>(py + kOffset * ny);
    sr.org_z = static_cast<float>(pz + kOffset * nz);
    sr.dir_x = static_cast<float>(L.u);
    sr.dir_y = static_cast<float>(L.w);
    sr.dir_z = static_cast<float>(L.n);
    sr.tnear = 0.f;
    sr.tfar = std::numeric_limits<float>::infinity();
    sr.mask = 0xFFFFFFFFu;
    sr.time = 0.f;
    sr.flags = 0;
    rtcOccluded1(impl_->scene, &ctx, &sr);
    ++m.rays;
    if (sr.tfar < 0.f) continue;  // shadowed
    const double cosV = ny * V.w + nz * V.n;
    const double rv = 2 * cosL * cosV - LdotV;
    const double spec = rv > 0 ? std::exp(n * std::log(rv)) : 0.0;
    sd += cosL;
    sd2 += cosL * cosL;
    ss += spec;
    ss2 += spec * spec;
  }
  if (hits) {
    const double N = static_cast<double>(hits);
    m.D = sd / N;
    m.S = ss / N;
    m.D_se = std::sqrt(std::max(sd2 / N - m.D * m.D, 0.0) / N);
    m.S_se = std::sqrt(std::max(ss2 / N - m.S * m.S, 0.0) / N);
  }
  return m;
}

MicroSweepSummary micro_sweep(const std::string& csv_path, double n, int rays, uint64_t seed,
                              const ProgressSink* progress) {
  const auto t0 = std::chrono::steady_clock::now();
  MicroSweepSummary sum;
  const double svals[] = {0.0, 0.25, 0.5, 0.75, 1.0};
  const double theta[] = {15, 45, 75}, phil[] = {0, 45, 90, 135}, phiv[] = {0, 90, 180, 270};
  std::ostringstream csv;
  csv << "s,theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,n,model_D,micro_D,micro_D_se,model_S,micro_"
         "S,micro_S_se\n";
  csv.precision(8);
  Progress bar("microgeometry sweep", 5 * 3 * 4 * 3 * 4, progress);
  for (double s : svals) {
    const MicroPatch patch(s);
    for (double tl : theta)
      for (double pl : phil)
        for (double tv : theta)
          for (double pv : phiv) {
            const double d = M_PI / 180;
            // phi from T toward B (the fiber frame: u = T, w = B).
            const LocalDir L{std::sin(tl * d) * std::cos(pl * d),
                             std::sin(tl * d) * std::sin(pl * d), std::cos(tl * d)};
            const LocalDir V{std::sin(tv * d) * std::cos(pv * d),
                             std::sin(tv * d) * std::sin(pv * d), std::cos(tv * d)};
            const MicroMeasurement m = patch.measure(L, V, n, rays, seed + sum.configs);
            double D, S;
            fiber_DS(L.w, L.n, V.w, V.n, L.u, V.u, n, s, FiberAccuracy{}, &D, &S);
            csv << s << "," << tl << "," << pl << "," << tv << "," << pv << "," << n << "," << D
                << "," << m.D << "," << m.D_se << "," << S << "," << m.S << "," << m.S_se << "\n";
            sum.max_dD = std::max(sum.max_dD, std::abs(D - m.D));
            sum.max_dS = std::max(sum.max_dS, std::abs(S - m.S));
            // The standard error of a stratified mean is below the plain one used here; floor it
            // at 1e-6 so exact agreements do not divide by zero.
            sum.max_zD = std::max(sum.max_zD, std::abs(D - m.D) / std::max(m.D_se, 1e-6));
            sum.max_zS = std::max(sum.max_zS, std::abs(S - m.S) / std::max(m.S_se, 1e-6));
            sum.rays += m.rays;
            ++sum.configs;
            bar.advance();
          }
  }
  write_text_file(csv_path, csv.str());
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace aniso
