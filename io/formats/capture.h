// The capture set of docs/formats.md (version 1): a folder with capture.json, images and geometry.
// The reader accepts exactly what docs/formats.md says, from whoever wrote it, and rejects what it
// does not understand with a message naming the file and the key.
#pragma once
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/image.h"
#include "core/vec.h"
#include "models/light.h"
#include "models/material.h"

namespace aniso {

struct GeometrySpec {
  std::string position, normal, tangent, mask, uv, topology;  // per-pixel buffers
  std::string mesh;                                           // or a triangle mesh (OBJ)
  std::string fiber_field;                                    // "", radial, circular, meridian
  bool empty() const { return position.empty() && mesh.empty(); }
};

struct ColorSpec {
  enum class Encoding { kLinear, kSrgb, kGamma };
  Encoding encoding = Encoding::kLinear;
  bool encoding_given = false;  // integer images need it stated (no silent assumption)
  double gamma = 2.2;
  double black_level = 0.0;
  double saturation = std::numeric_limits<double>::infinity();  // stored value; at/above: unused
  bool saturation_given = false;
};

// An integer image's stored value (scaled to [0, 1]) to linear. Below the black level the value
// keeps its sign (clipping to 0 would bias dark, noisy pixels upward); the curves are applied
// odd-symmetrically. EXR images are linear and never pass through here (docs/formats.md).
double decode_code(double v, const ColorSpec& c);

struct ViewSpec {
  std::string image;
  Mat4 world_from_camera;
  double exposure = 1.0;
  std::vector<Light> lights;
  Intrinsics camera;  // the set's camera unless the view overrides it
  GeometrySpec geometry;
  std::vector<std::string> source;  // the photo files the view came from (aniso import)
};

struct CaptureSet {
  std::string dir;   // folder holding capture.json; relative paths resolve against it
  std::string file;  // path of capture.json
  Intrinsics camera;
  ColorSpec color;
  RGB ambient{0, 0, 0};
  GeometrySpec geometry;
  std::vector<ViewSpec> views;
  std::string truth;         // material file with the ground truth, or ""
  std::string topology_map;  // known map m(u,v) (fiber model), or ""
  std::string provenance;    // JSON text of the optional "generator" block (seed, counters)
};

// Accepts the folder or its capture.json.
CaptureSet read_capture(const std::string& path);

// Every file a capture set names (capture.json, images, buffers, meshes, maps): what an output of
// a command reading the set must never replace.
std::vector<std::string> capture_input_files(const CaptureSet& set);
// Writes capture.json for `set` into set.dir (atomically). Paths in `set` are relative to it.
void write_capture_json(const CaptureSet& set, const std::string& path);

// Per-pixel geometry of a view, from its buffers or a traced mesh; shared (read-only) by every
// view that names the same buffers.
struct ViewGeometry {
  Image P, N, U;  // world position, unit normal, reference tangent
  Image smath;    // 1 channel: mathematical topology s_math (empty: no buffer, 0 everywhere)
  Image mapv;     // 1 channel: topology-map value m in [-1, 1] at the pixel's uv (empty: no map)
  Image uv;       // 2 channels, when the set has a uv buffer (empty otherwise)
  std::vector<uint8_t> mask;
  std::vector<uint8_t> finite;  // 1 where P, N, U (and uv, where there is one) are all finite
  std::vector<uint8_t> rows;    // 1 for each row that holds a mask pixel: the rows read of a view
  size_t mask_count = 0;        // pixels on the mask
  float smath_at(size_t p) const { return smath.empty() ? 0.f : smath.px[p]; }
  float mapv_at(size_t p) const { return mapv.empty() ? 0.f : mapv.px[p]; }
};

// One view loaded for fitting or verification: linear RGB image, per-pixel geometry, and which
// pixels are usable (mask on, finite, not saturated, geometry finite).
struct ViewData {
  Image rgb;  // 3 channels, linear, black level removed
  std::shared_ptr<const ViewGeometry> geo;
  // Per pixel, what it is (PixelUse): an observation (kUsable), left out (kSaturated,
  // kNonfinite), or neither: off the mask, or in a row not read (kOff).
  enum PixelUse : uint8_t { kOff = 0, kUsable = 1, kSaturated = 2, kNonfinite = 3 };
  std::vector<uint8_t> use;
  bool usable(size_t p) const { return use[p] == kUsable; }
  // The rows read of the image (one entry per row): the geometry's rows with a mask pixel, or the
  // band a caller asked for (ViewRows); no pixel of another row is an observation.
  std::vector<uint8_t> rows;
  // Of the rows read: the mask's pixels, those left out as saturated or not finite, the usable.
  size_t mask_pixels = 0, saturated = 0, nonfinite = 0, used = 0;
  int channels = 3;  // of the image: 1 (grey, repeated into rgb) or 3
  Vec3 eye;          // camera centre in world coordinates
};

// A topology map m(u, v) (docs/formats.md): first channel read as linear h in [0, 1] (integer
// images divided by their maximum), m = 2h - 1; glTF texture coordinates ((0,0) top-left, v down),
// bilinear with wrap-around.
struct TopologyMap {
  Image h;
  double sample(double u, double v) const;
};
TopologyMap load_topology_map(const std::string& path);

// Geometry buffers already decoded, for views loaded on any number of threads: views that name
// the same buffer files (a fixed camera, one geometry for every light) share one decoded copy,
// decoded once (a second thread asking for it waits for the first). Keeps the latest geometry for
// views still to come; the others live as long as a view holds them.
class GeometryCache {
 public:
  GeometryCache();
  ~GeometryCache();
  GeometryCache(const GeometryCache&) = delete;
  GeometryCache& operator=(const GeometryCache&) = delete;
  std::shared_ptr<const ViewGeometry> get(const std::string& key,
                                          const std::function<ViewGeometry()>& load);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// What names a view's geometry buffers (and its size): views with equal keys share one decoded
// geometry (a fixed camera).
std::string geometry_key(const ViewSpec& v);
// The set's geometries by key: the first view that names each, and how many do.
struct GeometryViews {
  size_t first = 0, views = 0;
};
std::map<std::string, GeometryViews> geometry_views(const CaptureSet& set);

// View i's per-pixel geometry alone (as load_view reads it, through `cache` where given).
std::shared_ptr<const ViewGeometry> load_view_geometry(const CaptureSet& set, size_t i,
                                                       const TopologyMap* map = nullptr,
                                                       GeometryCache* cache = nullptr);

// View i's mask (with ViewGeometry::rows) and uv buffer alone, the other buffers left empty and
// not read: where the pixels fall on the maps' grid (a count of them by texel row, before any
// band is read). Not a mesh's (its buffers are traced).
ViewGeometry load_view_uv(const CaptureSet& set, size_t i);

// The rows of a view's image to read, given its geometry (one entry per row, non-zero = read): for
// a caller that takes one band of the sample at a time. The image's other rows are neither read
// nor written (their values hold whatever a reused allocation held): their pixels are not
// classified (ViewData::use kOff) and none of them is an observation.
using ViewRows =
    std::function<const std::vector<uint8_t>&(const std::shared_ptr<const ViewGeometry>&)>;

// View i's geometry buffers (not a mesh) read in `rows` alone (of its mask's rows, which
// ViewGeometry::rows then holds): a band's rows of a geometry no other view shares, read band after
// band. Not cached; its buffers' allocations go back to the ExrReadBuffers alive when it goes.
std::shared_ptr<const ViewGeometry> load_view_geometry_rows(const CaptureSet& set, size_t i,
                                                            const TopologyMap* map,
                                                            const std::vector<uint8_t>& rows);

// Loads view i; per-pixel geometry comes from its buffers or by casting rays at its mesh.
// `map` (the set's topology map, loaded once by the caller) fills ViewGeometry::mapv from the uv
// buffer. With `cache`, buffers an earlier view also named are not decoded again. With `rows`,
// only those rows of the image (else every row with a mask pixel, the others 0).
// `lanes`: a float image's pixels sixteen at a time (AVX-512 F, BW, VL and BMI2) where the CPU has
// them, else one at a time (the tests hold both forms to the definitions).
ViewData load_view(const CaptureSet& set, size_t i, const TopologyMap* map = nullptr,
                   GeometryCache* cache = nullptr, const ViewRows* rows = nullptr,
                   bool lanes = true);
// The same into *into, whose allocation of pixel states (ViewData::use) is reused: a 2048^2 view's
// is 4 MB of fresh pages otherwise, view after view. That allocation is empty or all kOff (as
// clear_pixel_states leaves it): only the rows read are written, not the whole image's.
// With `geometry_rows` (one entry per row), the view's geometry buffers are read in those rows
// alone (load_view_geometry_rows), not through the cache.
void load_view_into(const CaptureSet& set, size_t i, ViewData* into, const TopologyMap* map,
                    GeometryCache* cache, const ViewRows* rows,
                    const std::vector<uint8_t>* geometry_rows = nullptr, bool lanes = true);
// d->use all kOff again, for another view's load_view_into: the rows read are cleared, the only
// ones whose states can be other than kOff (not the whole image's, megabytes a view a band).
void clear_pixel_states(ViewData* d);

}  // namespace aniso
