// The commands the plain `aniso` runs itself: the fit and those that need no more than it does
// (Embree, TBB, OpenEXR, Ceres, image files). Everything else -- demo, synth (its --photos draw
// with OpenCV), preview, view, board, import, bench, params, microgeometry, --help, --version, a
// typo -- goes to `aniso-full` beside it with the same command line, so a fit's process does not
// load OpenCV, OpenGL, GLFW or LibRaw (linked --as-needed: BENCHMARKS.md, "fit").
#include <cstring>

#include "cli/command.h"

namespace aniso::cli {

namespace {
constexpr const char* kHere[] = {"fit", "merge", "eval", "bake", "export", "verify"};
}  // namespace

std::vector<Command> register_commands(CLI::App& app) {
  return {add_fit(app),  add_merge(app),  add_eval(app),
          add_bake(app), add_export(app), add_verify(app)};
}

bool runs_here(int argc, char** argv) {
  if (argc < 2) return false;
  for (const char* name : kHere)
    if (std::strcmp(argv[1], name) == 0) return true;
  return false;
}

}  // namespace aniso::cli
