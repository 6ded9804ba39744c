// aniso plan: where to hold the lamp for a ring of camera positions, and how well a shoot (the
// plan, or an imported capture) covers the lobe (photo/import/plan.h).
#include <cstdio>
#include <memory>

#include "cli/command.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "photo/import/plan.h"
#include "photo/shoot/shoot.h"

namespace aniso::cli {

namespace {

void print_coverage(const Coverage& c, const char* what) {
  std::printf("plan: %s: %zu (photo, sample point) pairs; |L.T + V.T| (0 on the highlight):", what,
              c.samples);
  for (int b = 0; b < Coverage::kBands; ++b)
    std::printf(" %.2f-%.2f %zu%s", Coverage::kBandEdges[b], Coverage::kBandEdges[b + 1], c.band[b],
                b + 1 < Coverage::kBands ? "," : "\n");
  std::printf(
      "plan: photos showing the highlight on the sample by camera azimuth from the fiber "
      "(folded to 0-180): 0-45 %d, 45-90 %d, 90-135 %d, 135-180 %d\n",
      c.sectors[0], c.sectors[1], c.sectors[2], c.sectors[3]);
  if (c.missing.empty()) std::printf("plan: nothing missing\n");
  for (const auto& m : c.missing) std::printf("plan: missing: %s\n", m.c_str());
}

}  // namespace

Command add_plan(CLI::App& app) {
  struct Args {
    std::string shoot, capture, material;
    PlanOptions o;
  };
  auto a = std::make_shared<Args>();
  auto* c = app.add_subcommand(
      "plan",
      "Plan a photo shoot: for a ring of camera positions round the board, where to hold the "
      "lamp so that the sample's highlight falls on it; with --capture, how well an imported "
      "shoot covers the highlight and its fall-off, and what is missing");
  c->add_option("SHOOT", a->shoot, "shoot.json (its board, sample outline and tangent)")
      ->required();
  c->add_option("--capture", a->capture,
                "an imported capture of this shoot (aniso import): its cameras and lamps are "
                "checked instead of the ring");
  c->add_option("--material", a->material,
                "a fit of the sample: its fiber direction (default: the sample's tangent taken as "
                "the fiber direction)");
  c->add_option("--ring", a->o.ring, "camera positions round the board")->capture_default_str();
  c->add_option("--elevation", a->o.elevation_deg, "camera angle above the board, degrees")
      ->capture_default_str();
  c->add_option("--camera-m", a->o.camera_m, "camera distance from the sample, metres")
      ->capture_default_str();
  c->add_option("--lamp-m", a->o.lamp_m, "lamp distance from the sample, metres")
      ->capture_default_str();
  return {c, [a] {
            const Shoot s = read_shoot(a->shoot);
            PlanOptions o = a->o;
            if (!a->material.empty()) {
              const Material m = read_material(a->material);
              o.fiber_deg = m.fiber_angle_deg, o.fiber_given = true;
            }
            const std::vector<PlannedPhoto> ring = plan_ring(s, o);
            std::printf("plan: fiber direction %s\n",
                        o.fiber_given ? ("psi " + std::to_string(o.fiber_deg) + " deg from the " +
                                         "sample's tangent (" + a->material + ")")
                                            .c_str()
                                      : "taken as the sample's tangent (give --material FIT.json "
                                        "for a fitted one)");
            if (a->capture.empty()) {
              std::printf(
                  "plan: %d photos, camera %.0f deg above the board and %.2f m from the "
                  "sample, lamp %.2f m from it on the camera's mirror direction (board "
                  "frame, metres)\n",
                  o.ring, o.elevation_deg, o.camera_m, o.lamp_m);
              std::printf("%5s %10s  %-26s %-26s\n", "photo", "azimuth", "camera", "lamp");
              for (size_t i = 0; i < ring.size(); ++i) {
                char cam[64], lamp[64];
                std::snprintf(cam, sizeof cam, "(%.3f, %.3f, %.3f)", ring[i].camera.x,
                              ring[i].camera.y, ring[i].camera.z);
                std::snprintf(lamp, sizeof lamp, "(%.3f, %.3f, %.3f)", ring[i].lamp.x,
                              ring[i].lamp.y, ring[i].lamp.z);
                std::printf("%5zu %8.1f deg  %-26s %-26s\n", i, ring[i].azimuth_deg, cam, lamp);
              }
              print_coverage(lobe_coverage(s, photos_of(ring), o), "the ring above");
              return 0;
            }
            const CaptureSet set = read_capture(a->capture);
            const Coverage cov = lobe_coverage(s, photos_of(set), o, "view");
            for (size_t i = 0; i < cov.highlight_fraction.size(); ++i)
              std::printf(
                  "plan: view %zu: camera %.1f deg round from the fiber, highlight on "
                  "%.0f %% of the sample\n",
                  i, cov.azimuth_deg[i], 100 * cov.highlight_fraction[i]);
            print_coverage(cov, a->capture.c_str());
            return 0;
          }};
}

}  // namespace aniso::cli
