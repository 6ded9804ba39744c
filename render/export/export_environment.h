// `aniso export --env`: an environment prefiltered for the material (render/bake/environment.h,
// environment_fiber.h) as KTX2 volumes beside the shader that reads them, for the browser viewer
// and for an engine.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "models/material.h"
#include "render/bake/environment.h"
#include "render/export/export.h"

namespace aniso {

// Writes the tables and the shader into `dir` (the export's folder being written) and returns
// export.json's tables.environment; throws where environment_refusal(m) says why not.
nlohmann::json write_environment(const std::string& dir, const Material& m, const Environment& env,
                                 ExportSummary* sum);

}  // namespace aniso
