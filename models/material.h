// A material in plain numbers (the `aniso-material` file of docs/formats.md, without the fit's
// report). Typed: the model is an enum and the fiber model's topology source a variant, so a
// combination the format does not allow cannot be built. Strings are parsed once, by the file
// reader.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <variant>

#include "core/image.h"

namespace aniso {

using RGB = std::array<double, 3>;

enum class Model { kLine, kFiber };  // docs/models.md §3, §4

// The mathematical topology of a shape (docs/models.md §4): the capture's per-pixel `topology`
// buffer holds s_math for these.
enum class MathTopology { kNone, kTorus, kSphere };

// Where the fiber model's topology s comes from (docs/models.md §4), one of:
struct UniformS {  // one value for the whole (flat) sample
  double s = 0.0;
};
struct MathematicalS {  // the capture's per-pixel s_math buffer, as it is
  MathTopology kind = MathTopology::kTorus;
};
struct TopologyMapRef {  // a known map h(u,v) with amplitude A on top of s_math (Hast)
  std::string file;      // relative to the material file (or as named in a capture)
  double amplitude = 0.25;
  MathTopology over = MathTopology::kNone;
};
struct SMapRef {  // a map of s itself over uv (what `fit --topology-map N` writes)
  std::string file;
};
using Topology = std::variant<UniformS, MathematicalS, TopologyMapRef, SMapRef>;

// Per-texel maps over the sample's texture coordinates (docs/formats.md "Material maps"): each
// present map replaces its scalar wherever the sample has uv; the scalars hold the mean values.
// Images are shared (a Material is copied freely). kd, ks: RGB; n: R; fiber: R,G = (cos 2psi, sin
// 2psi); amplitude: R, the topology map's amplitude A per texel (the fiber model over a topology
// map, what `fit --maps --model fiber` writes for such a set; the topology's "amplitude" is its
// mean).
struct MaterialMaps {
  std::string kd_file, ks_file, n_file, fiber_file, amplitude_file;  // as named (relative to it)
  std::shared_ptr<const Image> kd, ks, n, fiber, amplitude;
  bool repeat = false;  // wrap "repeat" (default "clamp")
  bool any() const { return kd || ks || n || fiber || amplitude; }
};

struct Material {
  Model model = Model::kLine;
  RGB kd{0.2, 0.2, 0.2};
  RGB ks{0.5, 0.5, 0.5};
  double n = 40.0;
  double fiber_angle_deg = 0.0;
  RGB ka{0, 0, 0};
  // Optional terms: each is skipped when absent or when its weight is zero.
  bool has_isotropic = false;
  RGB iso_kd{0, 0, 0};
  RGB iso_ks{0, 0, 0};
  double iso_n = 20.0;
  bool has_second_fiber = false;
  double second_angle_deg = 90.0;
  double second_weight = 0.5;
  Topology topology;           // the fiber model's; unused by the line model
  MaterialMaps maps;           // spatially varying k_d, k_s, n, fiber direction (line model)
  std::string base_dir = ".";  // folder of the material file: relative map paths resolve here

  bool fiber() const { return model == Model::kFiber; }
  // The topology source when it is of kind X, else nullptr.
  template <class X>
  const X* topology_as() const {
    return std::get_if<X>(&topology);
  }
  template <class X>
  X* topology_as() {
    return std::get_if<X>(&topology);
  }
  // The shape's mathematical topology the source relies on (kNone for uniform s and maps of s).
  MathTopology mathematical() const {
    if (const auto* m = topology_as<MathematicalS>()) return m->kind;
    if (const auto* t = topology_as<TopologyMapRef>()) return t->over;
    return MathTopology::kNone;
  }
  // The one value of a uniform topology (0 for every other source).
  double uniform_s() const {
    const auto* u = topology_as<UniformS>();
    return u ? u->s : 0.0;
  }

  bool isotropic_active() const {
    return has_isotropic &&
           (iso_kd[0] + iso_kd[1] + iso_kd[2] + iso_ks[0] + iso_ks[1] + iso_ks[2]) > 0;
  }
  bool second_active() const { return has_second_fiber && second_weight < 1.0; }
};

inline const char* model_name(Model m) { return m == Model::kFiber ? "fiber" : "line"; }
inline const char* math_topology_name(MathTopology t) {
  return t == MathTopology::kTorus ? "torus" : t == MathTopology::kSphere ? "sphere" : "none";
}

}  // namespace aniso
