// The material file of docs/formats.md ("aniso-material", version 1).
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "models/material.h"

namespace aniso {

// Reads and validates against the bounds of models/params.h; errors name the file and key.
Material read_material(const std::string& path);
// The images of the maps a material names (docs/formats.md "Material maps"), relative to the folder
// of `path` (the file that names them, used in messages), checked as read_material checks them.
void load_material_maps(const std::string& path, Material* m);

// The material file and every map it names (resolved against its folder).
std::vector<std::string> material_input_files(const Material& m, const std::string& path);
// The image file a material at `path` names for a map: `block` "maps" (kd, ks, n, fiber, ...) or
// "maps_uncertainty" (kd, ..., determined, coverage, residual), resolved against its folder; ""
// where the file names none (fit --maps writes them as STEM_KEY.GEN.exr, one generation a run).
std::string named_map_file(const std::string& path, const std::string& block,
                           const std::string& key);
Material material_from_json(const nlohmann::json& j, const std::string& file);
void material_to_json(const Material& m, nlohmann::json* j);
// Writes `j` (a material plus any extra blocks) atomically; refuses non-finite numbers.
void write_json_file(const std::string& path, const nlohmann::json& j);

}  // namespace aniso
