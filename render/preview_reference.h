// render/ internal: the preview's check against the model itself. From the geometry pass (N, T,
// and T2 or (u, v, s_math) per fragment) every covered pixel is evaluated on the CPU: exactly,
// and for the fiber model also from the same baked tables, so the GPU's own error and the bake's
// error are told apart.
#pragma once
#include "core/image.h"
#include "render/bake.h"
#include "render/preview.h"

namespace aniso {

struct GBuffer {
  Image N, T, T2;  // T2 holds (u, v, s_math) for the fiber model
};

void fiber_reference(const Material& m, const PreviewOptions& opt, const Vec3& V,
                     const BakeTables& tables, const FiberBakeTables& fb, const GBuffer& g,
                     PreviewResult* res);
void line_reference(const Material& m, const PreviewOptions& opt, const Vec3& V,
                    const BakeTables& tables, const GBuffer& g, PreviewResult* res);

}  // namespace aniso
