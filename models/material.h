// A material in plain numbers (the `aniso-material` file of FORMAT.md, without the fit's report).
#pragma once
#include <array>
#include <string>

namespace aniso {

using RGB = std::array<double, 3>;

struct Material {
  std::string model = "line";  // "line" (MODELS.md §3) or "fiber" (§4)
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
  // Fiber model topology (MODELS.md §4): one value of s (flat samples), or a known map m(u,v)
  // with amplitude A on top of the mathematical topology ("torus": the capture's per-pixel
  // `topology` buffer holds s_math; "none": s_math = 0).
  bool has_topology = false;
  double topology_s = 0.0;
  bool has_topology_map = false;
  std::string topology_map;  // the map file, as named in the capture or material
  double topology_amplitude = 0.25;
  std::string topology_mathematical = "none";
  // Or a per-texel map of s itself over the uv buffer (what `fit --topology-map N` recovers): an
  // image whose first channel is s in [0, 1], sampled bilinearly with wrap (glTF uv).
  bool has_s_map = false;
  std::string topology_s_map;
  std::string base_dir = ".";  // folder of the material file: relative map paths resolve here

  // The topology value at a point with mathematical topology s_math and map value m in [-1, 1].
  double topology_at(double s_math, double m) const;

  bool isotropic_active() const {
    return has_isotropic &&
           (iso_kd[0] + iso_kd[1] + iso_kd[2] + iso_ks[0] + iso_ks[1] + iso_ks[2]) > 0;
  }
  bool second_active() const { return has_second_fiber && second_weight < 1.0; }
};

}  // namespace aniso
