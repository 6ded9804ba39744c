// aniso verify: renders a capture's views with a material and reports the error per view.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

#include "cli/command.h"
#include "io/files/files.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "render/preview/verify.h"

namespace aniso::cli {

Command add_verify(CLI::App& app) {
  struct Args {
    std::string cap, mat, resid;
    bool force = false;
  };
  auto a = std::make_shared<Args>();
  auto* ver = app.add_subcommand(
      "verify", "Render a capture's views with a material and report the error per view");
  ver->add_option("CAPTURE", a->cap, "capture folder or capture.json")->required();
  ver->add_option("MATERIAL", a->mat, "material file")->required();
  ver->add_option("--residuals", a->resid,
                  "folder for per-view residual images (model - image, float EXR)");
  add_force_flag(ver, &a->force);
  return {ver, [a] {
            const CaptureSet set = read_capture(a->cap);
            const Material m = read_material(a->mat);
            if (!a->resid.empty()) {
              std::vector<std::string> inputs = capture_input_files(set);
              for (const auto& f : material_input_files(m, a->mat)) inputs.push_back(f);
              check_outputs_apart({a->resid}, inputs);
              check_output_folder(a->resid, OutputKind::kResiduals, a->force);
            }
            const VerifyResult r = verify_capture(set, m, a->resid);
            std::printf("%-6s %8s %12s %12s %10s %10s %9s  %s\n", "view", "pixels", "rms",
                        "max_abs", "rel_rms", "noise", "rms/noise", "verdict");
            auto line = [](const char* name, const ViewError& e) {
              std::printf("%-6s %8zu %12.4g %12.4g %9.4f%% %10.4g %9.2f  %s\n", name, e.pixels,
                          e.rms, e.max_abs, 100 * e.rel_rms(), e.noise, e.rms_over_noise(),
                          verdict(e.rms_over_noise()));
            };
            for (size_t i = 0; i < r.views.size(); ++i) line(std::to_string(i).c_str(), r.views[i]);
            line("all", r.overall);
            const double q = r.overall.rms_over_noise();
            if (q > 3)
              std::printf(
                  "verify: WARNING: the residual is %.1f times the images' noise: the material "
                  "does not describe these images (for a photo shoot also: lamp positions, "
                  "intensities or the calibration)%s\n",
                  q, a->resid.empty() ? "; --residuals DIR shows where" : "");
            else if (q > 0)
              std::printf("verify: the residual is %.2f times the images' noise (%s)\n", q,
                          verdict(q));
            if (!a->resid.empty())
              std::printf(
                  "verify: %s/residual_NNN.exr (model - image, RGB) and residual_NNN.png (green "
                  "over each view's noise: blue -3 sigma, white 0, red +3 sigma; grey off the "
                  "sample)\n",
                  a->resid.c_str());
            if (r.overall.dark > 0) {
              std::string views;
              for (size_t i = 0; i < r.views.size(); ++i)
                if (r.views[i].dark > 0)
                  views += (views.empty() ? "" : ", ") + std::to_string(i) + " (" +
                           std::to_string(r.views[i].dark) + ")";
              std::printf(
                  "verify: NOTE: %zu pixels (%.2f %%) read under a quarter of what the material "
                  "predicts there, beyond the noise: a cast shadow or an occluder (verify traces "
                  "no shadow rays: "
                  "the sample's own geometry is only its buffers), or a material that does not "
                  "describe them. Without them the RMS is %.4g. Views (pixels): %s\n",
                  r.overall.dark, 100.0 * r.overall.dark / std::max<size_t>(r.overall.pixels, 1),
                  r.overall.rms_without_dark, views.c_str());
            }
            return 0;
          }};
}

}  // namespace aniso::cli
