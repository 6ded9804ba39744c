// fit/ internal: the loader's per-pixel geometry four pixels at a time (AVX2 without FMA, chosen
// at run time): the shading frame (core/frame.h make_frame), V and one point light in that frame
// (models/light.h light_at), each with the same operations in the same order as the scalar form,
// so with the same bits (IEEE division and square root are exact in either; the test
// FitPaths.PixelQuadsAreTheScalarFramesBitForBit holds them to it). The scalar form took a third
// of the load: ~6 square roots and ~13 divisions a pixel, one at a time.
#pragma once
#include "core/local_dir.h"
#include "core/vec.h"
#include "models/light.h"

namespace aniso::fitting {

struct PixelQuad {
  // In, per lane: the buffers' position, normal and tangent (their floats as doubles).
  double P[3][4], N[3][4], U[3][4];
  // Out of the frame's part, in to the light's: whether the buffers define a frame (make_frame's
  // test), its axes and V in it.
  bool frame_ok[4];
  double fU[3][4], fW[3][4], fN[3][4];
  LocalDir V[4];
  // Out of the light's part, per lane: L in the frame; the light's attenuation factor 1 / att;
  // whether the light reaches the point (r > 0, att > 0).
  LocalDir L[4];
  double f[4];
  bool lit[4];
};

// Whether the line model's four-pixel passes run: asked (FitOptions::line_lanes.simd, carried by
// the records as ObsSet::simd) and this CPU has AVX2 and FMA; the scalar forms otherwise.
bool line_lanes_on(bool asked);
struct ObsSet;  // fit/records/observations.h
bool line_lanes_on(const ObsSet& os);
// Fills q's outputs from its inputs for a camera at `eye` and one point light: the frame's part,
// then the light's.
void pixel_quad(const Vec3& eye, const Light& point, PixelQuad* q);
// The frame's part alone (from P, N, U: frame_ok, the axes, V), and the light's alone (from P and
// the axes: L, f, lit): views that share a geometry and an eye (a fixed camera) share the first.
void pixel_frame_quad(const Vec3& eye, PixelQuad* q);
void pixel_light_quad(const Light& point, PixelQuad* q);

// The light's part for pixels whose position and frame are arrays (fit/records/pixel_records.h
// SharedPixels: rows P x y z, U x y z, W x y z, N x y z, each `padded` long): kSharedLanes pixels
// from index i at once (eight lanes of AVX-512 where `avx512` and the CPU have it, else two of
// four), the same bits as pixel_light_quad.
constexpr int kSharedLanes = 8;
struct LightLanes {
  LocalDir L[kSharedLanes];
  double f[kSharedLanes];
  bool lit[kSharedLanes];
};
void shared_light_lanes(const Light& point, const double* frame, size_t padded, size_t i,
                        bool avx512, LightLanes* out);

}  // namespace aniso::fitting
