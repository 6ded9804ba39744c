#include "geometry/raycast.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "core/error.h"
#include "core/lens.h"
#include "geometry/embree_device.h"

namespace aniso {

namespace {

RTCDevice shared_device() {
  static std::once_flag once;
  static RTCDevice device = nullptr;
  std::call_once(once, [] { device = new_embree_device("ray casting"); });
  return device;
}

}  // namespace

struct RayScene::Impl {
  RTCScene scene = nullptr;
};

RayScene::RayScene(const TriMesh& mesh) : impl_(std::make_unique<Impl>()), mesh_(mesh) {
  RTCDevice dev = shared_device();
  impl_->scene = rtcNewScene(dev);
  RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.P.size()));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.tri.size()));
  if (!vb || !ib) throw Error("Embree: cannot allocate geometry buffers");
  for (size_t i = 0; i < mesh.P.size(); ++i) {
    vb[3 * i] = static_cast<float>(mesh.P[i].x);
    vb[3 * i + 1] = static_cast<float>(mesh.P[i].y);
    vb[3 * i + 2] = static_cast<float>(mesh.P[i].z);
  }
  for (size_t i = 0; i < mesh.tri.size(); ++i)
    for (int k = 0; k < 3; ++k) ib[3 * i + k] = mesh.tri[i][k];
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) throw Error("Embree: scene build failed");
}

RayScene::~RayScene() {
  if (impl_ && impl_->scene) rtcReleaseScene(impl_->scene);
}

bool RayScene::occluded(const Vec3& org, const Vec3& dir, double tfar) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray;
  ray.org_x = static_cast<float>(org.x);
  ray.org_y = static_cast<float>(org.y);
  ray.org_z = static_cast<float>(org.z);
  ray.dir_x = static_cast<float>(dir.x);
  ray.dir_y = static_cast<float>(dir.y);
  ray.dir_z = static_cast<float>(dir.z);
  ray.tnear = 0.f;
  ray.tfar =
      std::isfinite(tfar) ? static_cast<float>(tfar) : std::numeric_limits<float>::infinity();
  ray.time = 0.f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(impl_->scene, &ctx, &ray);
  return ray.tfar < 0.f;
}

namespace {

// Resizes an image to w x h x c, keeping its allocation when the size matches (every pixel is
// written by the trace, so nothing needs clearing).
void fit_image(Image* img, int w, int h, int c) {
  if (img->width == w && img->height == h && img->channels == c) return;
  *img = Image(w, h, c);
}

// Lane l of a packet: a primary ray from `eye` along `d`.
void start_ray(const Vec3& eye, const Vec3& d, int l, RTCRayHit8* rh) {
  rh->ray.org_x[l] = static_cast<float>(eye.x);
  rh->ray.org_y[l] = static_cast<float>(eye.y);
  rh->ray.org_z[l] = static_cast<float>(eye.z);
  rh->ray.dir_x[l] = static_cast<float>(d.x);
  rh->ray.dir_y[l] = static_cast<float>(d.y);
  rh->ray.dir_z[l] = static_cast<float>(d.z);
  rh->ray.tnear[l] = 0.f;
  rh->ray.tfar[l] = std::numeric_limits<float>::infinity();
  rh->ray.time[l] = 0.f;
  rh->ray.mask[l] = 0xFFFFFFFFu;
  rh->ray.id[l] = static_cast<unsigned>(l);
  rh->ray.flags[l] = 0;
  rh->hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
  rh->hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
}

// The four buffers of a trace, as raw pointers (the compiler cannot keep a GBuffer's vector
// pointers in registers across the float stores).
struct GBufferOut {
  float *P, *N, *U, *uv;
};

// Pixel p's buffers from a hit on triangle `prim` at barycentrics (b1, b2), distance t along the
// ray (eye, d): the position from the ray (exact on the triangle), the attributes interpolated.
// False (nothing written) where the ray meets the back of the surface: not a sample pixel.
bool store_hit(const TriMesh& m, FiberField field, const Vec3& eye, const Vec3& d, unsigned prim,
               double b1, double b2, float t, size_t p, const GBufferOut& g) {
  const auto& tri = m.tri[prim];
  const double b0 = 1.0 - b1 - b2;
  const Vec3 Nw = normalize(m.N[tri[0]] * b0 + m.N[tri[1]] * b1 + m.N[tri[2]] * b2);
  if (dot(Nw, d) >= 0.0) return false;
  const Vec3 Pw = eye + d * static_cast<double>(t);
  const Vec3 Uw = fiber_field_tangent(
      field, Pw, Nw, m.U[tri[0]] * b0 + m.U[tri[1]] * b1 + m.U[tri[2]] * b2, m.center, m.axis);
  float* P = g.P + 3 * p;
  float* N = g.N + 3 * p;
  float* U = g.U + 3 * p;
  for (int c = 0; c < 3; ++c) {
    P[c] = static_cast<float>(Pw[c]);
    N[c] = static_cast<float>(Nw[c]);
    U[c] = static_cast<float>(Uw[c]);
  }
  for (int c = 0; c < 2; ++c)
    g.uv[2 * p + c] =
        static_cast<float>(m.uv[tri[0]][c] * b0 + m.uv[tri[1]][c] * b1 + m.uv[tri[2]][c] * b2);
  return true;
}

}  // namespace

GBuffer RayScene::trace(const Intrinsics& k, const Mat4& pose, const std::string& field) const {
  GBuffer g;
  trace(k, pose, field, &g);
  return g;
}

void RayScene::trace(const Intrinsics& k, const Mat4& pose, const std::string& field,
                     GBuffer* out) const {
  GBuffer& g = *out;
  fit_image(&g.P, k.width, k.height, 3);
  fit_image(&g.N, k.width, k.height, 3);
  fit_image(&g.U, k.width, k.height, 3);
  fit_image(&g.uv, k.width, k.height, 2);
  g.hit.resize(static_cast<size_t>(k.width) * k.height);
  const Vec3 eye = pose.translation();
  const TriMesh& m = mesh_;
  const bool distorted = k.distorted();
  const FiberField field_kind = parse_fiber_field(field);
  const GBufferOut out_px{g.P.px.data(), g.N.px.data(), g.U.px.data(), g.uv.px.data()};
  uint8_t* const hits = g.hit.data();
  // A packet's directions in float, the lanes side by side (what Embree takes): a double
  // normalize per lane was a sqrt-and-divide latency chain that cost more than Embree's own work
  // on a primary ray. Columns past the image's width are padded and never valid.
  const int padded = (k.width + 7) / 8 * 8;
  std::vector<float> ray_x(static_cast<size_t>(padded), 0.f);  // camera-space x of each column
  for (int x = 0; x < k.width; ++x) ray_x[x] = static_cast<float>((x - k.cx) / k.fx);
  float R[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R[3 * r + c] = static_cast<float>(pose(r, c));
  tbb::parallel_for(tbb::blocked_range<int>(0, k.height), [&](const tbb::blocked_range<int>& rows) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(32) RTCRayHit8 rh;
    for (int l = 0; l < 8; ++l) start_ray(eye, Vec3(0, 0, 1), l, &rh);
    for (int y = rows.begin(); y < rows.end(); ++y) {
      const float ray_y = static_cast<float>((y - k.cy) / k.fy);
      for (int x0 = 0; x0 < k.width; x0 += 8) {
        alignas(32) int valid[8];
        if (distorted) {
          for (int l = 0; l < 8; ++l) {
            const int x = x0 + l;
            Vec3 r(ray_x[x], ray_y, 1.0);                               // padded: 0 past the width
            valid[l] = x < k.width && pixel_ray(k, x, y, &r) ? -1 : 0;  // inside the lens model
            start_ray(eye, normalize(pose.dir(r)), l, &rh);
          }
        } else {
          const float* rx = &ray_x[x0];
          for (int l = 0; l < 8; ++l) {
            const float dx = R[0] * rx[l] + R[1] * ray_y + R[2];
            const float dy = R[3] * rx[l] + R[4] * ray_y + R[5];
            const float dz = R[6] * rx[l] + R[7] * ray_y + R[8];
            const float inv = 1.f / std::sqrt(dx * dx + dy * dy + dz * dz);
            rh.ray.dir_x[l] = dx * inv, rh.ray.dir_y[l] = dy * inv, rh.ray.dir_z[l] = dz * inv;
            rh.ray.tfar[l] = std::numeric_limits<float>::infinity();
            rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
            valid[l] = x0 + l < k.width ? -1 : 0;
          }
        }
        rtcIntersect8(valid, impl_->scene, &ctx, &rh);
        for (int l = 0; l < 8 && x0 + l < k.width; ++l) {
          const size_t p = static_cast<size_t>(y) * k.width + x0 + l;
          const Vec3 d(rh.ray.dir_x[l], rh.ray.dir_y[l], rh.ray.dir_z[l]);
          const bool hit = valid[l] && rh.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID &&
                           store_hit(m, field_kind, eye, d, rh.hit.primID[l], rh.hit.u[l],
                                     rh.hit.v[l], rh.ray.tfar[l], p, out_px);
          hits[p] = hit;
          if (hit) continue;
          std::fill_n(out_px.P + 3 * p, 3, 0.f), std::fill_n(out_px.N + 3 * p, 3, 0.f);
          std::fill_n(out_px.U + 3 * p, 3, 0.f), std::fill_n(out_px.uv + 2 * p, 2, 0.f);
        }
      }
    }
  });
  g.rays = static_cast<size_t>(k.width) * k.height;
}

void trace_mesh_gbuffer(const std::string& obj_path, const std::string& field, const Intrinsics& k,
                        const Mat4& pose, Image* P, Image* N, Image* U,
                        std::vector<uint8_t>* mask) {
  const RayScene scene(load_obj(obj_path, field.empty()));
  GBuffer g = scene.trace(k, pose, field);
  *P = std::move(g.P);
  *N = std::move(g.N);
  *U = std::move(g.U);
  for (size_t i = 0; i < mask->size(); ++i) (*mask)[i] = (*mask)[i] && g.hit[i];
}

}  // namespace aniso
