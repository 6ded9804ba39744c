// aniso merge: the tiles of a `fit --maps --tile i/N` run joined into one material with maps.
#include <cstdio>
#include <memory>

#include "cli/command.h"
#include "core/error.h"
#include "fit/fit.h"
#include "io/files/files.h"
#include "io/images/image_io.h"

namespace aniso::cli {

Command add_merge(CLI::App& app) {
  struct Args {
    std::vector<std::string> tiles;
    std::string out, compression = "none";
    bool force = false;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "merge",
      "Join the tiles of `aniso fit CAPTURE --maps WxH --tile i/N` (one file per tile) into the "
      "material and its maps: the same files as one untiled run");
  c->add_option("TILES", a->tiles, "every tile's file")->required();
  c->add_option("--out", a->out, "material file to write (its maps go beside it)")->required();
  add_force_flag(c, &a->force);
  add_exr_compression(c, &a->compression,
                      "the maps (as `fit --maps` writes them: the same default)");
  return {c, [a] {
            const std::vector<std::string> outputs{a->out};
            check_outputs_apart(outputs, a->tiles);
            check_output_file(a->out, OutputKind::kMaterial, a->force);
            merge_maps_tiles(a->tiles, a->out, exr_compression_named(a->compression));
            std::printf("merge: %zu tiles -> %s (and its maps)\n", a->tiles.size(), a->out.c_str());
            return 0;
          }};
}

}  // namespace aniso::cli
