// `aniso export`'s tables/ folder (render/export/export.h): the lookup tables and the material's
// maps as KTX2 (and EXR), each file added to the summary's list and described in export.json's
// entries.
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "render/export/export.h"

namespace aniso {

// The line tables (and a fiber material's factor tables) into dir/tables/; export.json's
// "tables" entries.
nlohmann::json write_tables(const std::string& dir, const Material& m, const ExportOptions& o,
                            ExportSummary* sum);

// The material's maps into dir/tables/maps/ (and with a line material's map of n the stack of
// specular tables, added to *tables); export.json's "maps" entries. Sets sum->maps.
nlohmann::json write_maps(const std::string& dir, const Material& m, const ExportOptions& o,
                          ExportSummary* sum, nlohmann::json* tables);

}  // namespace aniso
