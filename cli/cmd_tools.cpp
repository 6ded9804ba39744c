// The small subcommands: microgeometry, bench, params.
#include <cstdio>
#include <memory>

#include "bench/suites.h"
#include "capture_sim/microgeometry.h"
#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "io/files/files.h"
#include "models/params.h"

namespace aniso::cli {

Command add_microgeometry(CLI::App& app) {
  struct Args {
    std::string out;
    int rays = 20000;
    double n = 20;
    uint64_t seed = 1;
    bool force = false;
  };
  auto a = std::make_shared<Args>();
  auto* micro = app.add_subcommand("microgeometry",
                                   "Virtual gonioreflectometer: measure a patch of Embree "
                                   "cylinders against the fiber model over a sweep of directions "
                                   "and topology values");
  micro->add_option("--out", a->out, "CSV with model and measured D, S per configuration")
      ->required();
  add_force_flag(micro, &a->force);
  micro->add_option("--rays", a->rays, "primary rays per configuration")
      ->capture_default_str()
      ->check(CLI::Range(100, 100000000));
  micro->add_option("--n", a->n, "specular exponent")
      ->capture_default_str()
      ->check(CLI::Range(line_param("n").lo, line_param("n").hi));
  micro->add_option("--seed", a->seed, "seed of the ray jitter")->capture_default_str();
  return {micro, [a] {
            check_output_file(a->out, OutputKind::kTable, a->force);
            const MicroSweepSummary m =
                micro_sweep(a->out, a->n, a->rays, a->seed, terminal_progress());
            std::printf(
                "microgeometry: %zu configurations (5 topology values x 144 direction pairs), "
                "%zu rays, %.1f s -> %s\n"
                "  model vs measured: max |dD| = %.2e (%.1f standard errors), max |dS| = %.2e "
                "(%.1f standard errors)\n",
                m.configs, m.rays, m.seconds, a->out.c_str(), m.max_dD, m.max_zD, m.max_dS,
                m.max_zS);
            return 0;
          }};
}

Command add_bench(CLI::App& app) {
  struct Args {
    std::string suite, out, work = "bench_work";
    bool quick = false, force = false;
  };
  auto a = std::make_shared<Args>();
  auto* bench = app.add_subcommand(
      "bench",
      "End-to-end comparisons in one run: fit (vs SciPy), fiber (vs brute force), bake, capture "
      "(vs bare Embree), preview (vs a plain pass), skips, measured (RGL files vs libbsdf), all");
  bench->add_option("SUITE", a->suite, "fit, fiber, bake, capture, preview, skips, measured or all")
      ->required();
  bench
      ->add_option("--out", a->out,
                   "JSON file of entries {name, ours, baseline, ratio, error, unit, ...}")
      ->required();
  bench
      ->add_option("--work", a->work,
                   "folder for the synthetic sets it makes: new, empty or an earlier bench's "
                   "(replaced run after run)")
      ->capture_default_str();
  add_force_flag(bench, &a->force);
  bench->add_flag("--quick", a->quick, "small sweeps (for tests)");
  return {bench, [a] {
            check_output_file(a->out, OutputKind::kBenchResult, a->force);
            // The work folder is claimed with the flag; the bench checks it again before use.
            if (a->force) check_output_folder(a->work, OutputKind::kBenchWork, true);
            run_bench(a->suite, a->out, a->work, a->quick);
            return 0;
          }};
}

Command add_params(CLI::App& app) {
  auto* params = app.add_subcommand(
      "params", "Print the model parameters: name, bounds, default, unit, periodic");
  return {params, [] {
            std::printf("%-24s %-8s %4s %10s %10s %8s %5s %8s %s\n", "key", "symbol", "dims", "min",
                        "max", "default", "unit", "periodic", "meaning");
            auto print = [](const ParamSpec& p, const char* model) {
              std::printf("%-24s %-8s %4d %10g %10g %8g %5s %8s %s\n", std::string(p.key).c_str(),
                          std::string(p.symbol).c_str(), p.dims, p.lo, p.hi, p.def,
                          p.unit.empty() ? "-" : std::string(p.unit).c_str(),
                          p.periodic ? "yes" : "no", (std::string(p.doc) + model).c_str());
            };
            for (const auto& p : kLineParams) print(p, "");
            for (const auto& p : kFiberParams) print(p, " [fiber model]");
            return 0;
          }};
}

}  // namespace aniso::cli
