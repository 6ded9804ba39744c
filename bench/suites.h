// `aniso bench SUITE --out FILE.json`: end-to-end comparisons made in one run on this machine.
// Every entry: {"suite", "name", "ours", "baseline", "ratio", "error", "unit", ...}; its target,
// where it has one, is checked and reported as met or missed, with the reason where missed.
#pragma once
#include <string>

namespace aniso {

// SUITE: fit, fiber, bake, capture, preview, skips, measured (RGL files vs libbsdf), or all.
// `work_dir` holds the synthetic sets. `quick` shrinks every sweep (for tests). Writes the JSON
// atomically and prints a summary.
void run_bench(const std::string& suite, const std::string& out_path, const std::string& work_dir,
               bool quick);

}  // namespace aniso
