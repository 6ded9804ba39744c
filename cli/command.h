// The CLI's pieces: each subcommand lives in its own cli/cmd_*.cpp, registers its options on the
// application and returns the function that runs it. main() only dispatches.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

#include "core/vec.h"

namespace aniso {
struct FitOptions;      // fit/types/fit_types.h
struct PreviewOptions;  // render/preview/preview.h
struct Material;        // models/material.h
}  // namespace aniso

namespace aniso::cli {

struct Command {
  CLI::App* sub = nullptr;
  std::function<int()> run;
};

Command add_demo(CLI::App& app);
Command add_report(CLI::App& app);
Command add_synth(CLI::App& app);
Command add_fit(CLI::App& app);
Command add_eval(CLI::App& app);
Command add_bake(CLI::App& app);
Command add_export(CLI::App& app);
Command add_preview(CLI::App& app);
Command add_verify(CLI::App& app);
Command add_microgeometry(CLI::App& app);
Command add_bench(CLI::App& app);
Command add_params(CLI::App& app);

// The commands this binary runs: every one (`aniso-full`, `aniso-mpi`: cli/commands_full.cpp), or
// the fit and its neighbours (`aniso`: cli/commands_lean.cpp), which hands every other command
// line to `aniso-full` beside it, so that a fit does not load the preview's and the photo
// import's libraries (OpenCV, OpenGL, GLFW, LibRaw: their loading is most of a small fit's
// process start; BENCHMARKS.md, "fit").
std::vector<Command> register_commands(CLI::App& app);
// False where this binary hands the command line to `aniso-full` (the lean `aniso` only).
bool runs_here(int argc, char** argv);
// Runs `name` from this binary's folder with the same command line (execv; never returns), or
// throws an Error that says `missing` when it is not there.
[[noreturn]] void run_beside(const std::string& name, const std::string& missing);

// `aniso fit` as a function (the demo runs it too): reads every input, fits, writes, prints.
int run_fit(const std::string& input, const FitOptions& fo, const std::string& out,
            const std::string& truth_path);

// The whole command line, recorded in outputs that say how they were made, and its words.
const std::string& command_line();
// The command as a person can share it, for an output at `out_dir`: the program as "aniso", and
// every word that names an existing file or folder (or an absolute path) relative to out_dir.
std::string shareable_command_line(const std::string& out_dir);
const std::vector<std::string>& command_words();
void set_command_line(int argc, char** argv);

// MPI where this binary has it (`aniso-mpi`, built with -DANISO_MPI=ON; cli/mpi_world.cpp):
// the world's rank and size, and a gather of every rank's (ok, bytes) at rank 0 (in rank order;
// an empty list on the other ranks). Null in the plain `aniso` (cli/mpi_none.cpp).
struct MpiWorld {
  int rank = 0, size = 1;
  std::function<std::vector<std::pair<bool, std::string>>(bool ok, const std::string& bytes)>
      gather;
  // Rank 0's (ok, bytes) on every rank (the arguments of the other ranks are ignored).
  std::function<std::pair<bool, std::string>(bool ok, const std::string& bytes)> broadcast;
};
const MpiWorld* mpi_world();

// `--size WxH` or `--size N` (errors name `opt`: --size, --maps).
void parse_size(const std::string& s, int* w, int* h, const char* opt = "--size");
// `--exr-compression` of a command that writes float EXRs (`what` names them in its help): none,
// zip or piz, into *value (its default is the command's); the command hands it to
// exr_compression_named (io/images/exr_compression.h) into the options it passes on.
void add_exr_compression(CLI::App* sub, std::string* value, const std::string& what);
// A non-zero direction "x,y,z" for option `opt`.
Vec3 parse_vec(const std::string& s, const std::string& opt);
// The fiber model's map the material names (relative to its file), or `map_override`, into the
// preview's options.
void load_material_maps(const Material& m, const std::string& map_override, PreviewOptions* p);
Command add_view(CLI::App& app);
Command add_board(CLI::App& app);
Command add_import(CLI::App& app);
Command add_merge(CLI::App& app);
Command add_plan(CLI::App& app);
// The shape to draw a material on: `given`, else the flat sample for a material with maps (their
// uv over [0, 1]^2, as the sample lies; a sphere wraps them with a seam, said on stderr by
// `command`) and the sphere otherwise.
std::string default_shape(const std::string& given, const Material& m, const char* command);

// `--force`: what the command would refuse to replace is moved aside, never deleted
// (io/files/files.h); `help` replaces the common text.
void add_force_flag(CLI::App* sub, bool* force, const char* help = nullptr);
// Says on stderr that a material's maps (k_d, k_s, n, fiber over uv) are not used by `what`, which
// takes the scalar (mean) values instead. Nothing when the material has no maps.
void note_material_maps(const Material& m, const char* what);

}  // namespace aniso::cli
