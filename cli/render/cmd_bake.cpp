// aniso bake: lookup tables of a material in a folder.
#include <cmath>
#include <cstdio>
#include <memory>

#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "render/bake/bake.h"

namespace aniso::cli {

Command add_bake(CLI::App& app) {
  struct Args {
    std::string mat, out, index = "angle";
    int size = 256;
    bool force = false;
  };
  auto a = std::make_shared<Args>();
  auto* bake =
      app.add_subcommand("bake", "Bake the lookup textures (EXR, 8/16-bit PNG, JSON sidecar)");
  bake->add_option("MATERIAL", a->mat, "material file")->required();
  bake->add_option("--out", a->out,
                   "output folder: new, empty, or an earlier aniso output (replaced atomically)")
      ->required();
  add_force_flag(bake, &a->force);
  bake->add_option("--size", a->size, "table size N (N x N)")
      ->capture_default_str()
      ->check(CLI::Range(2, 8192));
  bake->add_option("--index", a->index,
                   "texel spacing: angle (uniform in acos, default) or cosine (the paper's)")
      ->capture_default_str()
      ->check(CLI::IsMember({"angle", "cosine"}));
  return {bake, [a] {
            const Material m = read_material(a->mat);
            if (m.fiber())
              note_material_maps(m, "bake (the fiber model's tables; the maps are carried)");
            check_outputs_apart({a->out}, material_input_files(m, a->mat));
            check_output_folder(a->out, OutputKind::kBake, a->force);
            const BakeTables t = bake_line(m, a->size, parse_index(a->index));
            FiberBakeTables fb;
            if (m.fiber()) {
              fb = bake_fiber(m, t, 64, 9, 16, 1, terminal_progress());
              std::printf(
                  "bake: fiber factor tables %dx%dx%d (G) and x%d (F) in %.2f s; baked vs full "
                  "fiber model over %zu samples: max abs %.3g, p99 %.3g, RMS %.3g (peak %.3g)\n",
                  fb.nphi, fb.nphi, fb.ns, fb.nk, fb.seconds, fb.samples, fb.max_abs_error,
                  fb.p99_error, fb.rms_error, fb.peak_value);
            }
            // A line material's map of n: the specular tables over its range (render/bake/bake.h).
            SpecularStack st;
            const bool stack = !m.fiber() && m.maps.n;
            if (stack) {
              st = bake_material_stack(m, a->size, t.index);
              std::printf(
                  "bake: map of n (%.4g to %.4g): specular stack of %d levels, lookup vs direct "
                  "evaluation over %zu samples: max abs %.3g (of S)\n",
                  std::exp(st.logn0), std::exp(st.logn1), st.levels, st.samples, st.max_abs_error);
            }
            write_bake(a->out, m, t, shareable_command_line(a->out), m.fiber() ? &fb : nullptr,
                       stack ? &st : nullptr);
            std::printf(
                "bake: %dx%d tables (%s index) in %.3f s -> %s; bilinear lookup vs direct "
                "evaluation over %zu samples: max abs %.3g, RMS %.3g (peak value %.3g)\n",
                a->size, a->size, index_name(t.index), t.seconds, a->out.c_str(), t.samples,
                t.max_abs_error, t.rms_error, t.peak_value);
            return 0;
          }};
}

}  // namespace aniso::cli
