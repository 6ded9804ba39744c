// datasets_synth: named scenes from the papers with ground truth, and a seeded random-material
// generator for sweeps. Each preset is a SimOptions for capture_sim.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "capture_sim/sim.h"

namespace aniso {

class ProgressSink;  // core/progress.h

struct PresetOptions {
  int views = 16;
  int width = 128, height = 128;
  double noise = 0.0;         // Gaussian read noise, fraction of the white level
  double shot_photons = 0.0;  // photons at the white level (0 = none)
  int bits = 0;               // 0 = float EXR, 8/16 = PNG
  std::string encoding = "linear";
  double saturation = 0;  // clip at this fraction of the white level (0 = no clipping)
  std::string rig;        // "" = the preset's own, "fixed-camera", "orbit", or a rig JSON file
  uint64_t seed = 1;
  const ProgressSink* progress = nullptr;  // core/progress.h; null: silent
  // Fiber-model presets.
  double topology_s = 0.3;        // fiber-flat: the sample's topology value
  std::string topology_map_file;  // silk-torus: any image (first channel = h); default procedural
  double topology_amplitude = 0.25;
};

// A tileable, seeded value-noise map (h in [0, 1]) for topology maps.
Image procedural_topology_map(int size, uint64_t seed);

// (name, description) of every preset.
const std::vector<std::pair<std::string, std::string>>& preset_list();

SimOptions make_preset(const std::string& name, const PresetOptions& opt);

// A plausible line-model material drawn from a seeded generator (for sweeps).
Material random_material(uint64_t seed);

}  // namespace aniso
