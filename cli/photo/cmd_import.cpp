// aniso import: a photo shoot to a capture set (photo/import/import.h).
#include <cstdio>
#include <memory>

#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "core/error.h"
#include "io/files/files.h"
#include "photo/import/import.h"

namespace aniso::cli {

namespace {

struct ImportArgs {
  std::string shoot, out, compression = "zip", raw_develop = "aniso";
  ImportOptions o = [] {
    ImportOptions i;
    i.progress = terminal_progress();
    return i;
  }();
  double margin_mm = 3;
  bool no_overlays = false, quiet = false, lamps_as_written = false, no_vignetting = false;
  bool force = false;
};

int run(const ImportArgs& a) {
  const Shoot s = read_shoot(a.shoot);
  check_output_folder(a.out, OutputKind::kImportedCapture, a.force);
  std::vector<std::string> inputs{a.shoot};
  for (const auto& p : s.photos)
    for (const auto& im : p.images) inputs.push_back(join_path(s.dir, im.file));
  check_outputs_apart({a.out}, inputs);
  ImportOptions o = a.o;
  o.compression = exr_compression_named(a.compression);
  o.overlays = !a.no_overlays;
  o.find_lamps = !a.lamps_as_written;
  o.vignetting = !a.no_vignetting;
  o.raw_develop = raw_develop_named(a.raw_develop);
  o.sample_margin_m = a.margin_mm / 1000;
  const ImportResult r = import_shoot(s, a.out, o);
  const Intrinsics& k = r.camera;
  if (r.calibrated)
    std::printf(
        "import: camera calibrated from %zu photos: %dx%d, fx %.2f fy %.2f (sigma %.2f %.2f) px, "
        "centre (%.2f, %.2f), distortion k1 %.4f k2 %.4f p1 %.5f p2 %.5f (k3 fixed 0), RMS %.3f "
        "px\n",
        r.calibrated_on, k.width, k.height, k.fx, k.fy, r.sigma[0], r.sigma[1], k.cx, k.cy,
        k.distortion[0], k.distortion[1], k.distortion[2], k.distortion[3], r.calibration_rms_px);
  else
    std::printf("import: camera given in the shoot: %dx%d, fx %.2f fy %.2f px\n", k.width, k.height,
                k.fx, k.fy);
  for (const std::string& h : r.held) std::printf("import: held: %s\n", h.c_str());
  for (size_t i = 0; i < r.photos.size(); ++i) {
    const ImportedPhoto& p = r.photos[i];
    const std::string name = s.photos[i].images[0].file;
    if (!p.accepted) {
      std::fprintf(stderr, "import: photo %zu (%s): LEFT OUT: %s\n", i, name.c_str(),
                   p.reason.c_str());
      continue;
    }
    if (a.quiet) continue;
    const Vec3 e = p.world_from_camera.translation();
    std::printf(
        "import: photo %zu (%s): %d corners (%d at the sample dropped), RMS %.3f px, camera at "
        "(%.4f, %.4f, %.4f) m, tilt %.1f deg, %zu sample pixels\n",
        i, name.c_str(), p.corners, p.corners_dropped, p.rms_px, e.x, e.y, e.z, p.tilt_deg,
        p.sample_pixels);
    for (const LampFound& l : p.lamps) {
      if (!l.solved) {
        std::printf("import:   lamp as written (%s)\n", l.why.c_str());
        continue;
      }
      std::printf(
          "import:   lamp found at (%.4f, %.4f, %.4f) +- (%.4f, %.4f, %.4f) m from %zu paper "
          "points (shading %.2f %% RMS), %.1f mm from the written one; intensity %.4g (written "
          "%.4g)\n",
          l.found.x, l.found.y, l.found.z, l.sigma_m[0], l.sigma_m[1], l.sigma_m[2], l.points,
          100 * l.paper_rms, 1000 * length(l.found - l.written), l.found_intensity[1],
          l.written_intensity[1]);
    }
  }
  if (r.vignetting.found)
    std::printf(
        "import: vignetting from the paper of %zu photos: V(r) = 1 %+.4f r^2 %+.4f r^4 (+- %.4f, "
        "%.4f), %.3f at the frame's corner (the paper reached r = %.2f); %s\n",
        r.vignetting.photos, r.vignetting.a1, r.vignetting.a2, r.vignetting.sigma_a1,
        r.vignetting.sigma_a2, r.vignetting.at(0, 0), r.vignetting.r_max,
        r.vignetting.applied ? "taken out of the views" : "not told from 1 there, so not used");
  for (const std::string& w : r.warnings) std::fprintf(stderr, "import: WARNING: %s\n", w.c_str());
  size_t decoded_twice = 0;
  for (const auto& p : r.photos) decoded_twice += p.decoded_twice;
  const std::string twice =
      decoded_twice ? " (" + std::to_string(decoded_twice) +
                          " decoded twice: their samples' regions were not kept between the passes)"
                    : "";
  std::printf(
      "import: %zu of %zu photos -> %s (%zu views; import_report.json, overlays/); %.2f s "
      "(merge+detect %.2f, calibrate+pose %.2f, write %.2f); %d photos merged at once within "
      "--memory %.0f MB (merges %.0f MB, samples' regions up to %.0f MB)%s\n"
      "import: lamp intensities %s\n"
      "import: then: aniso fit %s --out material.json\n",
      r.views, r.photos.size(), a.out.c_str(), r.views, r.seconds, r.seconds_detect,
      r.seconds_calibrate, r.seconds_write, r.merge_threads, o.memory_mb, r.memory_estimate_mb,
      r.crop_budget_mb, twice.c_str(), r.intensities.c_str(), a.out.c_str());
  return 0;
}

}  // namespace

Command add_import(CLI::App& app) {
  auto a = std::make_shared<ImportArgs>();
  auto* c = app.add_subcommand(
      "import",
      "Turn a photo shoot (shoot.json: photos of a sample on a printed ChArUco board, see "
      "aniso board) into a capture set: calibrate the camera, solve each photo's pose, merge "
      "exposure brackets, and write per-pixel geometry of the sample");
  c->add_option("SHOOT", a->shoot, "shoot.json (docs/formats.md \"Photo shoot\")")->required();
  c->add_option("--out", a->out,
                "capture folder to write: new, empty, or an earlier aniso output (replaced "
                "atomically)")
      ->required();
  c->add_option("--max-rms", a->o.max_rms_px,
                "leave out photos whose board corners reproject worse than this (pixels)")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 100.0));
  c->add_option("--sample-margin-mm", a->margin_mm,
                "also drop board corners this close to the sample's outline (mm)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  c->add_option("--min-corners", a->o.min_corners, "fewer board corners found: photo left out")
      ->capture_default_str()
      ->check(CLI::Range(4, 10000));
  c->add_option("--memory", a->o.memory_mb,
                "memory budget of the whole import, MB: photos are merged as many at once as fit, "
                "the merged region around each sample kept between the passes while it fits "
                "(else the photo is decoded again); a shoot whose one photo does not fit is "
                "refused before decoding")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e7));
  c->add_option("--calibrate-on", a->o.calibrate_on,
                "calibrate the camera on at most this many photos, spread over the shoot (its "
                "cost grows as their cube); the others are posed against it")
      ->capture_default_str()
      ->check(CLI::Range(4, 100000));
  c->add_flag("--lamps-as-written", a->lamps_as_written,
              "take every lamp's position and intensity as the shoot writes them, instead of "
              "finding them from the board's paper (a shoot whose lamps were measured exactly)");
  c->add_flag("--no-overlays", a->no_overlays, "do not write overlays/NNN.png");
  c->add_flag("--no-vignetting", a->no_vignetting,
              "take the lens as free of vignetting (by default it is found from the board's "
              "paper and taken out of the views' images)");
  add_exr_compression(c, &a->compression, "the views' images and geometry buffers");
  c->add_option("--raw-develop", a->raw_develop,
                "who develops RAW files: aniso (streamed a row at a time, a Bayer mosaic by "
                "bilinear interpolation: LibRaw's own arithmetic, its memory 2 bytes a pixel), "
                "libraw (LibRaw's dcraw_process, bilinear, whole) or libraw-ahd (LibRaw's AHD "
                "demosaic: finer colour at sharp edges, slowest)")
      ->capture_default_str()
      ->check(CLI::IsMember({"aniso", "libraw", "libraw-ahd"}));
  c->add_flag("--quiet", a->quiet, "print only the summary and the photos left out");
  add_force_flag(c, &a->force);
  return {c, [a] { return run(*a); }};
}

}  // namespace aniso::cli
