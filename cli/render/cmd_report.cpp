// aniso report: a fit as a folder of pictures and tables a person can open (render/report/).
#include <cstdio>
#include <memory>

#include "cli/command.h"
#include "io/files/files.h"
#include "render/report/report_page.h"

namespace aniso::cli {

Command add_report(CLI::App& app) {
  auto a = std::make_shared<ReportOptions>();
  auto force = std::make_shared<bool>(false);
  auto* c = app.add_subcommand(
      "report",
      "Write a fit as a page a person can open offline (DIR/index.html): the parameters with their "
      "whole and noise-only sigma, the warnings apart from the notes, the maps' previews, the "
      "fiber direction as a field, sigma and coverage per texel, the correlation matrix as a heat "
      "map, the solver's convergence, the phases' times; with --capture, the residuals against "
      "the unit Gaussian, the lobe against the data in the fiber's frame, the half vectors the "
      "capture saw, and each view's residual picture and its RMS against the images' noise");
  c->add_option("FIT", a->material, "material file that aniso fit wrote")->required();
  c->add_option("--capture", a->capture,
                "what it was fitted to: a capture set (each view against the model, the residuals "
                "and the lobe against the data), or a sample table .csv or measured .bsdf file "
                "(its readings' lobe against the fitted one)");
  c->add_option("--out", a->out, "folder to write (index.html and its pictures)")->required();
  add_force_flag(c, force.get());
  return {c, [a, force] {
            std::vector<std::string> inputs{a->material};
            if (!a->capture.empty()) inputs.push_back(a->capture);
            check_outputs_apart({a->out}, inputs);
            check_output_folder(a->out, OutputKind::kText, *force);
            const ReportSummary s = write_report(*a);
            std::printf(
                "report: %s -> %s/index.html: %zu parameters, %zu warnings, %zu notes, %zu map "
                "pictures%s, %zu views, %zu points in the lobe plots\n",
                a->material.c_str(), a->out.c_str(), s.parameters, s.warnings, s.notes, s.maps,
                s.correlation ? ", the correlation matrix" : "", s.views, s.lobe_points);
            return 0;
          }};
}

}  // namespace aniso::cli
