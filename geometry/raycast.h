// Ray casting against a triangle mesh with Embree 3: per-pixel geometry buffers for a camera and
// shadow queries. Embree's headers stay in raycast.cpp.
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/image.h"
#include "geometry/mesh.h"

namespace aniso {

struct GBuffer {
  Image P, N, U, uv;         // 3, 3, 3, 2 channels
  std::vector<uint8_t> hit;  // 1 = the pixel sees the front of the surface
  size_t rays = 0;           // primary rays cast
};

class RayScene {
 public:
  explicit RayScene(const TriMesh& mesh);
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  // Casts one primary ray per pixel (8-wide packets) and interpolates the mesh's attributes;
  // `fiber_field` replaces dP/du where given. Multithreaded over rows.
  GBuffer trace(const Intrinsics& k, const Mat4& world_from_camera,
                const std::string& fiber_field) const;
  // The same into `g`, whose buffers are kept when they already have the camera's size (every
  // pixel is written: a view after another reuses the memory without clearing it).
  void trace(const Intrinsics& k, const Mat4& world_from_camera, const std::string& fiber_field,
             GBuffer* g) const;
  // True if the segment org + t dir, t in (0, tfar), hits the mesh.
  bool occluded(const Vec3& org, const Vec3& dir, double tfar) const;
  const TriMesh& mesh() const { return mesh_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  TriMesh mesh_;
};

// Loads an OBJ and traces its geometry buffers (used by the capture reader for mesh geometry).
void trace_mesh_gbuffer(const std::string& obj_path, const std::string& fiber_field,
                        const Intrinsics& k, const Mat4& world_from_camera, Image* P, Image* N,
                        Image* U, std::vector<uint8_t>* mask);

}  // namespace aniso
