// capture_sim: a simulated gonioreflectometer. Ray casts a shape (Embree), shades every sample
// pixel with the ground-truth material under each view's lights (docs/models.md §2-3), applies a
// sensor model, and writes a capture set exactly per docs/formats.md.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "geometry/topology.h"
#include "io/formats/capture.h"
#include "io/images/exr_compression.h"
#include "models/material.h"

namespace aniso {

class ProgressSink;  // core/progress.h

struct RigView {
  Mat4 world_from_camera;
  std::vector<Light> lights;
};

// Rigs over the hemisphere above the sample (z up). Deterministic: golden-angle spirals.
// fixed camera, moving light: the camera sits at `camera_polar_deg`; the light visits `views`
// positions between 10 and 70 degrees from the normal at all azimuths.
std::vector<RigView> rig_fixed_camera(int views, double camera_polar_deg, double distance);
// both moving: camera and light each follow their own spiral.
std::vector<RigView> rig_orbit(int views, double distance);
// Explicit list: a JSON file {"views": [{"camera": [x,y,z], "target": [..], "lights": [..]}]}
// with lights as in docs/formats.md.
std::vector<RigView> rig_from_file(const std::string& path);

struct SensorOptions {
  double read_noise = 0.0;          // Gaussian sigma, as a fraction of the white level
  double shot_photons = 0.0;        // photons collected at the white level (0 = no shot noise)
  int bits = 0;                     // 0 = float EXR, 8 or 16 = PNG
  std::string encoding = "linear";  // for PNG: linear or srgb
  double saturation = std::numeric_limits<double>::infinity();  // fraction of white level
};

struct SimOptions {
  std::string shape = "flat";  // a shape name or an .obj path
  ShapeOptions shape_options;
  std::string fiber_field;  // "", radial, circular, meridian
  Material truth;
  Intrinsics camera;
  std::vector<RigView> rig;
  RGB ambient{0, 0, 0};
  SensorOptions sensor;
  uint64_t seed = 1;
  std::string preset;                                 // recorded in the set
  const ProgressSink* progress = nullptr;             // core/progress.h; null: silent
  ExrCompression compression = ExrCompression::kZip;  // the images and geometry buffers
  // Fiber model topology. "torus" / "sphere": the per-pixel mathematical topology s_math of that
  // shape is written as the `topology` buffer. A non-empty map (values h in [0, 1]) is stored as
  // maps/topology.png (16-bit) and named by the set's "topology_map".
  MathTopology mathematical_topology = MathTopology::kNone;
  Image topology_map;
  // A per-texel map of s itself (first channel, [0, 1]) over uv; stored as maps/topology_s.png
  // and named by the truth material's topology.s_map.
  Image s_map;
  // Benchmark switches that turn a skip off, to measure what it saves: shadow rays even for
  // shapes that cannot shadow themselves; re-tracing the geometry of every view of a fixed camera.
  bool force_shadows = false;
  bool force_retrace = false;
  // Benchmark switch: trace and shade every view, write nothing (no folder either), to measure
  // what writing the set costs against a ray loop that writes nothing.
  bool write_files = true;
  // A noisy, clipped or integer sensor needs the white level of all views before any is written:
  // their radiance is kept up to this many bytes (12 per pixel and view); beyond it every view is
  // traced and shaded twice, the white level first, and memory stays that of two views.
  double kept_radiance_bytes = 1e9;
};

struct SimStats {
  size_t views = 0, primary_rays = 0, shadow_rays = 0, shaded_pixels = 0, light_evals = 0;
  size_t lights_culled = 0;  // (view, light) pairs skipped: the light reaches no sample pixel
  double white_level = 0, seconds = 0;
  double seconds_trace = 0, seconds_shade = 0, seconds_write = 0;  // where the time went
  int passes = 1;  // 2: traced and shaded twice (the white level first; kept_radiance_bytes)
};

// Writes the capture set into out_dir (atomically: a temporary folder renamed at the end).
SimStats simulate_capture(const SimOptions& opt, const std::string& out_dir);

// A camera framing an object of radius `radius` at `distance`, square image of width x height.
Intrinsics frame_camera(int width, int height, double radius, double distance);

}  // namespace aniso
