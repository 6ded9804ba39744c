// `aniso export`'s engines/ folder: for each of Godot 4, Unity (Shader Graph) and Unreal a folder a
// person drops into a project, drawing the line model from the export's EXR tables with the
// material's values filled in (docs/engines.md).
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <utility>
#include <vector>

#include "models/material.h"

namespace aniso {

// The packages' files (path in the export folder, text) for a line material with one set of
// values and N x N tables; none for the fiber model or a material with maps, whose shaders/ hold
// what an engine needs. *entry is export.json's "engines": what each folder holds, how it was
// checked, and what it does not draw.
// A number as a shader literal, with a point or an exponent always (GLSL ES converts no int to
// float).
std::string shader_float(double v);

std::vector<std::pair<std::string, std::string>> engine_packages(const Material& m, int texels,
                                                                 nlohmann::json* entry);

}  // namespace aniso
