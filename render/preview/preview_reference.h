// render/ internal: the preview's check against the model itself. From the geometry pass (N, T,
// and T2 or (u, v, s_math) per fragment) every covered pixel is evaluated on the CPU: exactly,
// and for the fiber model also from the same baked tables, so the GPU's own error and the bake's
// error are told apart.
#pragma once
#include "core/image.h"
#include "render/bake/bake.h"
#include "render/preview/preview.h"

namespace aniso {

struct GBuffer {
  Image N, T, T2;  // T2 holds (u, v, s_math) for the fiber model
  Image P;         // position
  Image UV;        // (u, v, 0)
};

// The viewer: distant (the paper's: V constant) or at `eye` (perspective).
struct PreviewCamera {
  Vec3 V;  // toward the viewer, unit
  bool perspective = false;
  Vec3 eye;
  float view_proj[16];
  Vec3 toward_viewer(const Vec3& P) const { return perspective ? normalize(eye - P) : V; }
};

// With a map of n (`stack` and `fstack`: S_line and F over its range) each fragment's n is the
// map's, in the exact evaluation and in the baked one.
void fiber_reference(const Material& m, const PreviewOptions& opt, const PreviewCamera& cam,
                     const std::vector<PreviewLight>& lights, const BakeTables& tables,
                     const FiberBakeTables& fb, const SpecularStack* stack,
                     const FiberStack* fstack, const GBuffer& g, PreviewResult* res);
// With maps (`stack`: the specular tables over the map's n, when it has one) every fragment
// evaluates material_at(u, v), and the bound takes the maps' largest k_d and k_s.
void line_reference(const Material& m, const PreviewOptions& opt, const PreviewCamera& cam,
                    const std::vector<PreviewLight>& lights, const BakeTables& tables,
                    const SpecularStack* stack, const GBuffer& g, PreviewResult* res);
// Under an environment: brute force, the exact model at each covered fragment (the fiber model at
// the fragment's topology s) summed over the environment's directions (averaged to w x h cells);
// the differences from res->rgb.
void environment_reference(const Material& m, const PreviewOptions& opt, const PreviewCamera& cam,
                           const Environment& env, int w, int h, const GBuffer& g,
                           PreviewResult* res);

}  // namespace aniso
