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
  tbb::parallel_for(tbb::blocked_range<int>(0, k.height), [&](const tbb::blocked_range<int>& rows) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x0 = 0; x0 < k.width; x0 += 8) {
        alignas(32) int valid[8];
        alignas(32) RTCRayHit8 rh;
        Vec3 dirs[8];
        for (int l = 0; l < 8; ++l) {
          const int x = x0 + l;
          valid[l] = x < k.width ? -1 : 0;
          Vec3 r((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
          if (distorted && !pixel_ray(k, x, y, &r)) valid[l] = 0;  // outside the lens model
          const Vec3 d = normalize(pose.dir(r));
          dirs[l] = d;
          rh.ray.org_x[l] = static_cast<float>(eye.x);
          rh.ray.org_y[l] = static_cast<float>(eye.y);
          rh.ray.org_z[l] = static_cast<float>(eye.z);
          rh.ray.dir_x[l] = static_cast<float>(d.x);
          rh.ray.dir_y[l] = static_cast<float>(d.y);
          rh.ray.dir_z[l] = static_cast<float>(d.z);
          rh.ray.tnear[l] = 0.f;
          rh.ray.tfar[l] = std::numeric_limits<float>::infinity();
          rh.ray.time[l] = 0.f;
          rh.ray.mask[l] = 0xFFFFFFFFu;
          rh.ray.id[l] = static_cast<unsigned>(l);
          rh.ray.flags[l] = 0;
          rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
          rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect8(valid, impl_->scene, &ctx, &rh);
        for (int l = 0; l < 8 && x0 + l < k.width; ++l) {
          const int x = x0 + l;
          const size_t p = static_cast<size_t>(y) * k.width + x;
          float* P = &g.P.px[3 * p];
          float* N = &g.N.px[3 * p];
          float* U = &g.U.px[3 * p];
          float* uv = &g.uv.px[2 * p];
          g.hit[p] = 0;
          std::fill(P, P + 3, 0.f), std::fill(N, N + 3, 0.f), std::fill(U, U + 3, 0.f);
          uv[0] = uv[1] = 0.f;
          if (!valid[l] || rh.hit.geomID[l] == RTC_INVALID_GEOMETRY_ID) continue;
          const auto& t = m.tri[rh.hit.primID[l]];
          const double b1 = rh.hit.u[l], b2 = rh.hit.v[l], b0 = 1.0 - b1 - b2;
          // Position from the ray (exact on the triangle), attributes interpolated.
          const Vec3 Pw = eye + dirs[l] * static_cast<double>(rh.ray.tfar[l]);
          const Vec3 Nw = normalize(m.N[t[0]] * b0 + m.N[t[1]] * b1 + m.N[t[2]] * b2);
          if (dot(Nw, dirs[l]) >= 0.0) continue;  // back side: not a sample pixel
          Vec3 Uw = m.U[t[0]] * b0 + m.U[t[1]] * b1 + m.U[t[2]] * b2;
          Uw = fiber_field_tangent(field_kind, Pw, Nw, Uw, m.center, m.axis);
          g.hit[p] = 1;
          for (int c = 0; c < 3; ++c) {
            P[c] = static_cast<float>(Pw[c]);
            N[c] = static_cast<float>(Nw[c]);
            U[c] = static_cast<float>(Uw[c]);
          }
          for (int c = 0; c < 2; ++c)
            uv[c] =
                static_cast<float>(m.uv[t[0]][c] * b0 + m.uv[t[1]][c] * b1 + m.uv[t[2]][c] * b2);
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
