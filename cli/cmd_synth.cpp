// aniso synth: a ground-truth capture set from a named preset.
#include <cstdio>
#include <memory>

#include "capture_sim/sim.h"
#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "core/error.h"
#include "datasets_synth/presets.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "photo/import/synth_shoot.h"

namespace aniso::cli {

namespace {
struct SynthArgs {
  std::string preset, out, size = "128x128", truth, compression = "none", walk = "turned",
                           brdf = "truth";
  PresetOptions po = [] {
    PresetOptions p;
    p.progress = terminal_progress();
    return p;
  }();
  double kept_gb = SimOptions{}.kept_radiance_bytes / 1e9;  // --kept-radiance-gb: the library's
  bool list = false, photos = false, dng = false, bayer = false, jpeg = false,
       hide_intensity = false, fill_lamp = false, force = false;
  double lamp_error_m = 0, ggx_alpha_b = PhotoShootOptions{}.ggx_alpha_b,
         paper = PhotoShootOptions{}.paper_albedo, grey_card = 0, vignetting = 0;
  CLI::App* app = nullptr;
};

// --photos: a photo shoot of the preset's material on a ChArUco board (photo/import/synth_shoot.h).
int run_photos(const SynthArgs& a) {
  PhotoShootOptions o;
  o.progress = terminal_progress();
  o.truth = a.truth.empty() ? make_preset(a.preset, a.po).truth : read_material(a.truth);
  o.seed = a.po.seed;
  if (a.app->count("--size")) parse_size(a.size, &o.width, &o.height);
  if (a.app->count("--views")) o.photos = a.po.views;
  if (a.app->count("--noise")) o.read_noise = a.po.noise;
  if (a.po.bits == 16) o.raw16 = true;
  o.dng = a.dng || a.bayer;
  o.bayer = a.bayer;
  o.jpeg = a.jpeg;
  o.walk = a.walk;
  o.lamp_error_m = a.lamp_error_m;
  o.hide_intensity = a.hide_intensity;
  o.brdf = a.brdf;
  o.ggx_alpha_b = a.ggx_alpha_b;
  o.paper_albedo = a.paper;
  o.grey_card = a.grey_card;
  o.vignetting = a.vignetting;
  o.fill_lamp = a.fill_lamp;
  check_output_folder(a.out, OutputKind::kPhotoShoot, a.force);
  check_outputs_apart({a.out}, {a.truth});
  const PhotoShootStats st = simulate_photo_shoot(o, a.out);
  std::printf(
      "synth --photos: %s -> %s: %zu photos x %zu exposures, %dx%d %s, seed %llu; %zu primary "
      "rays, %zu shadow rays, %.1f%% of codes saturated; %.2f s\n"
      "synth --photos: then: aniso import %s/shoot.json --out CAPTURE_DIR\n",
      a.preset.c_str(), a.out.c_str(), st.photos, o.bracket.size(), o.width, o.height,
      o.bayer   ? "Bayer (RGGB) DNG"
      : o.dng   ? "linear DNG"
      : o.jpeg  ? "8-bit sRGB JPEG"
      : o.raw16 ? "16-bit linear"
                : "8-bit sRGB",
      static_cast<unsigned long long>(o.seed), st.primary_rays, st.shadow_rays,
      100.0 * st.saturated_codes / (3.0 * o.width * o.height * st.images), st.seconds,
      a.out.c_str());
  return 0;
}

int run(const SynthArgs& a) {
  if (a.list) {
    for (const auto& [name, desc] : preset_list())
      std::printf("%-14s %s\n", name.c_str(), desc.c_str());
    return 0;
  }
  if (a.preset.empty() || a.out.empty())
    throw Error("synth: needs PRESET and OUT_DIR (see --list)");
  if (a.photos) return run_photos(a);
  PresetOptions po = a.po;
  parse_size(a.size, &po.width, &po.height);
  check_output_folder(a.out, OutputKind::kCapture, a.force);
  check_outputs_apart({a.out}, {a.truth, po.topology_map_file, po.rig});
  SimOptions so = make_preset(a.preset, po);
  so.compression = exr_compression_named(a.compression);
  if (!a.truth.empty()) so.truth = read_material(a.truth);
  so.kept_radiance_bytes = a.kept_gb * 1e9;
  const SimStats st = simulate_capture(so, a.out);
  std::printf(
      "synth: %s -> %s: %zu views %dx%d, seed %llu; %zu primary rays, %zu shadow rays, %zu "
      "shaded pixels, %zu light evaluations, %zu (view, light) pairs culled; %.2f s (trace %.2f, "
      "shade %.2f, write %.2f)%s\n",
      a.preset.c_str(), a.out.c_str(), st.views, po.width, po.height,
      static_cast<unsigned long long>(po.seed), st.primary_rays, st.shadow_rays, st.shaded_pixels,
      st.light_evals, st.lights_culled, st.seconds, st.seconds_trace, st.seconds_shade,
      st.seconds_write,
      st.passes == 2 ? "; every view shaded twice, the white level first (memory: two views)" : "");
  return 0;
}
}  // namespace

Command add_synth(CLI::App& app) {
  auto a = std::make_shared<SynthArgs>();
  PresetOptions& po = a->po;
  auto* synth = app.add_subcommand("synth", "Make a ground-truth capture set from a named preset");
  synth->add_option("PRESET", a->preset, "preset name (--list shows them)");
  synth->add_option("OUT_DIR", a->out,
                    "capture folder to write: new, empty, or an earlier aniso output (replaced "
                    "atomically)");
  synth->add_flag("--list", a->list, "list the presets and exit");
  synth->add_flag("--photos", a->photos,
                  "write a photo shoot instead (shoot.json, bracketed photos of the preset's "
                  "material on a ChArUco board through a distorting lens, truth.json): the input "
                  "of aniso import. Defaults then: --size 960x720, --views 24 photos, --noise "
                  "0.002; --bits 16 writes RAW-like 16-bit linear photos");
  synth->add_flag("--jpeg", a->jpeg,
                  "--photos: write 8-bit sRGB JPEGs (quality 95), as a camera does");
  synth->add_flag("--dng", a->dng,
                  "--photos: write linear DNG files (16-bit, three channels a pixel, read by aniso "
                  "import through LibRaw)");
  synth->add_flag("--bayer", a->bayer,
                  "--photos: write DNG files as a camera's sensor records them: one channel a "
                  "pixel in an RGGB mosaic (16-bit), demosaiced at import");
  synth
      ->add_option("--walk", a->walk,
                   "--photos: how the camera is held: upright (walking round the board, level "
                   "with the horizon, 40-70 degrees above it: a person's shoot) or turned (turned "
                   "with the board)")
      ->capture_default_str()
      ->check(CLI::IsMember({"upright", "turned"}));
  synth
      ->add_option("--lamp-error", a->lamp_error_m,
                   "--photos: write each lamp's position off by N(0, this) metres per axis, as a "
                   "tape measure does (truth.json keeps the true ones; import finds them from the "
                   "board's paper)")
      ->check(CLI::Range(0.0, 0.2));
  synth->add_flag("--hide-intensity", a->hide_intensity,
                  "--photos: write every lamp's intensity as 1, as a person who does not know it "
                  "would (import finds it from the board's paper)");
  synth
      ->add_option("--brdf", a->brdf,
                   "--photos: render the sample with its material's own model (truth) or with an "
                   "anisotropic GGX microfacet BRDF of the same k_d, k_s and fiber angle (ggx: "
                   "roughness sqrt(2/(n+2)) along the fibers, --ggx-alpha-b across them), a model "
                   "the fit does not have, as another renderer would give")
      ->capture_default_str()
      ->check(CLI::IsMember({"truth", "ggx"}));
  synth
      ->add_option("--ggx-alpha-b", a->ggx_alpha_b,
                   "--photos --brdf ggx: the GGX roughness across the fibers")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1.0));
  synth
      ->add_option("--paper-reflectance", a->paper,
                   "--photos: the printed paper's diffuse reflectance (not written in the shoot: "
                   "a person does not know it; import assumes 0.85 without a reference)")
      ->capture_default_str()
      ->check(CLI::Range(0.3, 1.0));
  synth
      ->add_option("--grey-card", a->grey_card,
                   "--photos: lay a grey card of this reflectance (0.18: a photographer's card) "
                   "on the board's top-left corner and write it as the shoot's reference, which "
                   "makes the lamps' intensities, k_d and k_s absolute")
      ->check(CLI::Range(0.02, 1.0));
  synth
      ->add_option("--vignetting", a->vignetting,
                   "--photos: the lens's vignetting, a pixel reading 1 + this r^2 of the scene (r "
                   "from the image's centre over the half diagonal; -0.3: 30 % darker corners)")
      ->check(CLI::Range(-0.79, 0.5));
  synth->add_flag("--fill-lamp", a->fill_lamp,
                  "--photos: light every photo with a second lamp, a fill beside the camera at 0.4 "
                  "of the key lamp's irradiance (both written in the shoot)");
  a->app = synth;
  add_force_flag(synth, &a->force);
  synth
      ->add_option("--noise", po.noise,
                   "Gaussian read noise sigma, as a fraction of the white level (0.01 = 1%)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  synth
      ->add_option("--shot", po.shot_photons,
                   "Poisson shot noise: photons at the white level (0 = off, at most 1e12)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e12));
  synth->add_option("--seed", po.seed, "seed for every random draw (recorded in capture.json)")
      ->capture_default_str();
  synth->add_option("--views", po.views, "number of views")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  synth->add_option("--size", a->size, "image size WxH")->capture_default_str();
  synth->add_option("--bits", po.bits, "0 = float EXR, 8 or 16 = PNG")
      ->capture_default_str()
      ->check(CLI::IsMember({0, 8, 16}));
  synth->add_option("--encoding", po.encoding, "PNG encoding")
      ->capture_default_str()
      ->check(CLI::IsMember({"linear", "srgb"}));
  synth
      ->add_option("--saturation", po.saturation,
                   "sensor clips at this fraction of the white level (0 = never); clipped values "
                   "are flagged in capture.json so the fit leaves them out")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  synth->add_option("--rig", po.rig,
                    "fixed-camera, orbit, or a rig JSON file (default: the preset's)");
  synth->add_option("--truth", a->truth, "use this material file as the ground truth instead");
  add_exr_compression(synth, &a->compression, "the images and geometry buffers");
  synth->add_option("--topology-s", po.topology_s, "fiber-flat: the sample's topology value s")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  synth->add_option("--topology-map", po.topology_map_file,
                    "silk-torus: topology map image (default: seeded noise)");
  synth->add_option("--amplitude", po.topology_amplitude, "silk-torus: topology map amplitude A")
      ->capture_default_str()
      ->check(CLI::Range(-2.0, 2.0));
  synth
      ->add_option("--kept-radiance-gb", a->kept_gb,
                   "noise, clipping or integer images need the white level of all views before "
                   "any is written: keep up to this many GB of radiance (12 bytes per pixel and "
                   "view); beyond it every view is traced and shaded twice, the white level "
                   "first, in the memory of two views (0: always twice)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  return {synth, [a] { return run(*a); }};
}

}  // namespace aniso::cli
