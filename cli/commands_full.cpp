// Every command: `aniso-full` and `aniso-mpi` (the lean `aniso` hands them what it does not run).
#include "cli/command.h"

namespace aniso::cli {

std::vector<Command> register_commands(CLI::App& app) {
  return {add_demo(app),          add_synth(app),  add_fit(app),     add_eval(app),
          add_bake(app),          add_export(app), add_preview(app), add_verify(app),
          add_microgeometry(app), add_bench(app),  add_params(app),  add_view(app),
          add_board(app),         add_import(app), add_merge(app),   add_plan(app),
          add_report(app)};
}

bool runs_here(int, char**) { return true; }

}  // namespace aniso::cli
