#include "capture_sim/sim.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include "core/angles.h"
#include "core/color.h"
#include "core/error.h"
#include "core/frame.h"
#include "core/gauss.h"
#include "core/progress.h"
#include "core/texture.h"
#include "core/timer.h"
#include "geometry/raycast.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "models/evaluate.h"
#include "models/material_maps.h"
#include "models/shade.h"
#include "models/topology.h"

namespace aniso {

namespace {

// An image of w x h x c filled with `v`, reusing its memory when it has one of that size.
void refill(Image* img, int w, int h, int c, float v) {
  img->width = w, img->height = h, img->channels = c;
  img->px.assign(static_cast<size_t>(w) * h * c, v);
}

// Noise-free radiance image of one view (exposure 1), shading every hit pixel. `topo` holds the
// topology value s of each pixel (fiber model).
void shade_view(const Evaluator& eval, const Material& truth, const GBuffer& g, const Image& topo,
                const Vec3& eye, const std::vector<Light>& lights, const RGB& ambient,
                const RayScene& scene, bool force_shadows, std::atomic<size_t>* shadow_rays,
                std::atomic<size_t>* light_evals, std::vector<uint8_t>* light_used, Image* img,
                double* brightest) {
  const int w = g.P.width, h = g.P.height;
  refill(img, w, h, 3, 0.f);
  Image& out = *img;
  const bool shadows = scene.mesh().can_self_shadow || force_shadows;
  std::vector<std::atomic<uint8_t>> used(lights.size());
  for (auto& u : used) u = 0;
  std::atomic<float> peak{0.f};
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    ShadeCounters cnt;
    float local_peak = 0.f;
    std::vector<uint8_t> local_used(lights.size(), 0);
    auto occluded = [&](const SurfacePoint& sp, const Vec3& L, double dist, ShadeCounters* c) {
      if (!shadows) return false;
      ++c->shadow_rays;
      // Leave the surface along N by more than the float precision of the scene (size ~1).
      constexpr double kShadowOffset = 1e-4;
      return scene.occluded(sp.P + sp.N * kShadowOffset, L, dist - 2 * kShadowOffset);
    };
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        if (!g.hit[static_cast<size_t>(y) * w + x]) continue;
        SurfacePoint sp;
        if (!frame_at(g.P, g.N, g.U, x, y, &sp)) continue;
        double I[3];
        // A material with maps is evaluated with its values at the pixel's texture coordinates.
        const Evaluator local =
            truth.maps.any() ? Evaluator(material_at(truth, g.uv.at(x, y, 0), g.uv.at(x, y, 1)))
                             : eval;
        shade_point(local, sp, eye, lights,
                    {truth.ka[0] * ambient[0], truth.ka[1] * ambient[1], truth.ka[2] * ambient[2]},
                    topo.at(x, y, 0), occluded, I, &cnt, &local_used);
        for (int c = 0; c < 3; ++c) {
          const float v = static_cast<float>(I[c]);
          out.at(x, y, c) = v;
          local_peak = std::max(local_peak, v);
        }
      }
    for (float seen = peak.load();
         local_peak > seen && !peak.compare_exchange_weak(seen, local_peak);) {
    }
    *shadow_rays += cnt.shadow_rays;
    *light_evals += cnt.light_evals;
    for (size_t i = 0; i < lights.size(); ++i)
      if (local_used[i]) used[i] = 1;
  });
  light_used->resize(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) (*light_used)[i] = used[i];
  *brightest = peak.load();
}

void check_sim_options(const SimOptions& opt) {
  if (opt.rig.empty()) throw Error("capture_sim: the rig has no views");
  if (opt.camera.width < 1 || opt.camera.height < 1)
    throw Error("capture_sim: camera size must be positive");
  if (opt.sensor.bits != 0 && opt.sensor.bits != 8 && opt.sensor.bits != 16)
    throw Error("capture_sim: bit depth must be 0 (float), 8 or 16");
  if (opt.sensor.encoding != "linear" && opt.sensor.encoding != "srgb")
    throw Error("capture_sim: encoding must be linear or srgb");
  if (opt.sensor.read_noise < 0 || opt.sensor.shot_photons < 0)
    throw Error("capture_sim: noise levels must be non-negative");
  // Poisson sampling with a mean beyond this takes unbounded time in libstdc++ and adds nothing:
  // the relative shot noise is already below 1e-6.
  constexpr double kMaxShotPhotons = 1e12;
  if (opt.sensor.shot_photons > kMaxShotPhotons)
    throw Error("capture_sim: --shot must be at most 1e12 photons");
  if (opt.truth.fiber() && opt.truth.topology_as<TopologyMapRef>() && opt.topology_map.empty())
    throw Error("capture_sim: the material uses a topology map but none was given");
  if (opt.truth.fiber() && opt.truth.topology_as<SMapRef>() && opt.s_map.empty())
    throw Error("capture_sim: the material uses a map of s but none was given");
}

// A map as the set stores it (16-bit PNG), so the fit sees exactly what was rendered.
Image quantised16(Image img) {
  for (float& v : img.px)
    v = static_cast<float>(std::round(std::clamp(v, 0.f, 1.f) * 65535.0) / 65535.0);
  return img;
}

// Per-pixel topology s_math and s of a traced pose; constant images when neither the material
// nor the set needs them (the line model without a mathematical topology).
void topology_images(const SimOptions& opt, const TopologyMap& map, const Image& s_map,
                     const GBuffer& g, Image* smath, Image* s) {
  refill(smath, g.P.width, g.P.height, 1, 0.f);
  refill(s, g.P.width, g.P.height, 1, static_cast<float>(opt.truth.uniform_s()));
  if (!opt.truth.fiber() && opt.mathematical_topology == MathTopology::kNone) return;
  for (int y = 0; y < g.P.height; ++y)
    for (int x = 0; x < g.P.width; ++x) {
      if (!g.hit[static_cast<size_t>(y) * g.P.width + x]) continue;
      const float sm = static_cast<float>(mathematical_topology_at(
          opt.mathematical_topology, pixel_vec3(g.P, x, y), opt.shape_options));
      smath->at(x, y, 0) = sm;
      const double u = g.uv.at(x, y, 0), v = g.uv.at(x, y, 1);
      double mv = map.h.empty() ? 0.0 : map.sample(u, v);
      if (!s_map.empty()) mv = sample_first_channel(s_map, u, v);
      s->at(x, y, 0) = static_cast<float>(s_at(opt.truth, sm, mv, u, v));
    }
}

// The geometry buffers of one pose under `dir`, named after `stem`: their names, and one job per
// file in *jobs (each writes its file when called; g and smath must outlive them).
GeometrySpec geometry_files(const std::string& dir, const GBuffer& g, const Image& smath,
                            const std::string& stem, bool with_topology, ExrCompression c,
                            std::vector<std::function<void()>>* jobs) {
  GeometrySpec gs;
  gs.position = "geometry/" + stem + "_P.exr";
  gs.normal = "geometry/" + stem + "_N.exr";
  gs.tangent = "geometry/" + stem + "_U.exr";
  gs.uv = "geometry/" + stem + "_uv.exr";
  gs.mask = "geometry/" + stem + "_mask.png";
  auto exr = [&](const std::string& rel, const Image& img) {
    jobs->push_back([path = join_path(dir, rel), &img, c] { write_exr(path, img, c); });
  };
  exr(gs.position, g.P);
  exr(gs.normal, g.N);
  exr(gs.tangent, g.U);
  exr(gs.uv, g.uv);
  jobs->push_back(
      [path = join_path(dir, gs.mask), &g] { write_mask_png(path, g.hit, g.P.width, g.P.height); });
  if (with_topology) {
    gs.topology = "geometry/" + stem + "_topology.exr";
    exr(gs.topology, smath);
  }
  return gs;
}

// What the sensor records of view i's radiance, in place: exposure, shot and read noise from the
// view's own generator (seeded from (seed, view): the same set whatever the threading), clipping
// at saturation, encoding and quantisation.
struct SensorLevels {
  double exposure = 1, white = 0, saturation = 0;
};
SensorLevels sensor_levels(const SimOptions& opt, double white_level) {
  // Integer images: the white level maps to 0.8 so noise has headroom; float keeps exposure 1.
  SensorLevels lv;
  lv.exposure = opt.sensor.bits ? 0.8 / white_level : 1.0;
  lv.white = lv.exposure * white_level;
  lv.saturation = opt.sensor.saturation * lv.white;
  return lv;
}
void apply_sensor(const SimOptions& opt, const SensorLevels& lv, size_t view, Image* img) {
  std::seed_seq seq{static_cast<uint32_t>(opt.seed), static_cast<uint32_t>(opt.seed >> 32),
                    static_cast<uint32_t>(view)};
  std::mt19937_64 rng(seq);
  const ZigguratNormal gauss;
  for (float& px : img->px) {
    double val = lv.exposure * px;
    if (opt.sensor.shot_photons > 0) {
      std::poisson_distribution<long long> pois(
          std::max(val / lv.white * opt.sensor.shot_photons, 0.0));
      val = static_cast<double>(pois(rng)) * lv.white / opt.sensor.shot_photons;
    }
    if (opt.sensor.read_noise > 0) val += opt.sensor.read_noise * lv.white * gauss(rng);
    if (val > lv.saturation) val = lv.saturation;
    if (opt.sensor.bits) {
      val = opt.sensor.encoding == "srgb" ? srgb_encode(val) : std::clamp(val, 0.0, 1.0);
      const double q = opt.sensor.bits == 8 ? 255.0 : 65535.0;
      val = std::round(val * q) / q;
    }
    px = static_cast<float>(val);
  }
}

// Whether the sensor records the radiance as it is: float, exposure 1, no noise, no clipping (the
// synth default). Then no view needs the white level of all of them before it can be written.
bool sensor_is_identity(const SensorOptions& s) {
  return s.bits == 0 && s.read_noise == 0 && s.shot_photons == 0 && !std::isfinite(s.saturation);
}

// View i's files are named after its index: "007".
std::string view_stem(size_t i) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "%03zu", i);
  return stem;
}

std::string view_image_name(size_t i, int bits) {
  return "images/" + view_stem(i) + (bits ? ".png" : ".exr");
}

// View i's image as the sensor records it, from its radiance (changed in place).
void write_view_image(const std::string& dir, const SimOptions& opt, const SensorLevels& lv,
                      size_t i, Image* radiance) {
  if (!sensor_is_identity(opt.sensor)) apply_sensor(opt, lv, i, radiance);
  const std::string path = join_path(dir, view_image_name(i, opt.sensor.bits));
  if (opt.sensor.bits)
    write_png(path, *radiance, opt.sensor.bits);
  else
    write_exr(path, *radiance, opt.compression);
}

// What is traced per camera pose, and the views' noise-free radiance. Two sets of geometry
// buffers: one is written to disk in the background while the next pose is traced into the other.
// The views' images: every view's radiance kept for the white level (kKeep); each view written as
// the sensor records it with its pose's geometry, from one of two buffers (kWrite: the white level
// is known, or not needed); or nothing written, the white level only (kMeasure).
struct Traced {
  enum class Images { kKeep, kWrite, kMeasure } images = Images::kKeep;
  SensorLevels levels;  // kWrite
  GBuffer g[2];
  Image smath[2], s[2];  // per pixel: s_math (the `topology` buffer) and s (for shading)
  std::vector<Image> radiance;
  Image shaded[2];  // kWrite, kMeasure: the view being shaded and the one being written
  std::vector<GeometrySpec> geometry;  // per view (moving camera) or one for all (fixed)
  bool fixed_camera = true;            // every view shares the first view's pose: one geometry
  const char* label = "capture_sim: tracing and shading";  // the progress bar's
};

// Traces every pose and shades every view. The geometry of each pose is written under `dir` in
// the background (a fixed camera's once, as "all") while the next view is traced and shaded, and
// its buffers are reused; so is a written view's image (tr->images says which views are written).
void trace_and_shade(const SimOptions& opt, const RayScene& scene, const TopologyMap& map,
                     const Image& s_map, const std::string& dir, Traced* tr, SimStats* st) {
  for (const auto& v : opt.rig)
    if (v.world_from_camera.m != opt.rig[0].world_from_camera.m) tr->fixed_camera = false;
  const bool with_topology = opt.mathematical_topology != MathTopology::kNone;
  tr->geometry.resize(tr->fixed_camera ? 1 : opt.rig.size());
  const Evaluator eval(opt.truth);
  std::atomic<size_t> shadow_rays{0}, light_evals{0};
  Progress bar(tr->label, opt.rig.size(), opt.progress);
  tbb::task_group writer;  // at most one view's files in flight
  auto wait_writer = [&] {
    const auto tw = std::chrono::steady_clock::now();
    writer.wait();
    st->seconds_write += seconds_since(tw);
  };
  try {
    int b = 0;
    for (size_t i = 0; i < opt.rig.size(); ++i) {
      const bool traced = i == 0 || !tr->fixed_camera || opt.force_retrace;
      if (traced) {
        b = tr->fixed_camera ? (i == 0 ? 0 : 1) : static_cast<int>(i % 2);
        const auto tt = std::chrono::steady_clock::now();
        scene.trace(opt.camera, opt.rig[i].world_from_camera, opt.fiber_field, &tr->g[b]);
        st->seconds_trace += seconds_since(tt);
        st->primary_rays += tr->g[b].rays;
        topology_images(opt, map, s_map, tr->g[b], &tr->smath[b], &tr->s[b]);
      }
      const GBuffer& g = tr->g[b];
      using Images = Traced::Images;
      Image* img = tr->images == Images::kKeep ? &tr->radiance.emplace_back() : &tr->shaded[i % 2];
      std::vector<uint8_t> used;
      double brightest = 0;  // the image's largest value (the pixels it does not shade are 0)
      const auto ts = std::chrono::steady_clock::now();
      shade_view(eval, opt.truth, g, tr->s[b], opt.rig[i].world_from_camera.translation(),
                 opt.rig[i].lights, opt.ambient, scene, opt.force_shadows, &shadow_rays,
                 &light_evals, &used, img, &brightest);
      st->seconds_shade += seconds_since(ts);
      st->white_level = std::max(st->white_level, brightest);
      for (uint8_t u : used) st->lights_culled += u ? 0 : 1;
      for (uint8_t hit : g.hit) st->shaded_pixels += hit;
      const bool geometry =
          traced && (i == 0 || !tr->fixed_camera) && tr->images != Images::kMeasure;
      const bool image = tr->images == Images::kWrite;
      if (geometry || image) {
        wait_writer();  // the other buffers are on disk
        const std::string name = tr->fixed_camera ? "all" : view_stem(i);
        GeometrySpec* spec = geometry ? &tr->geometry[tr->fixed_camera ? 0 : i] : nullptr;
        std::vector<std::function<void()>> jobs;
        if (spec)
          *spec = geometry_files(dir, g, tr->smath[b], name, with_topology, opt.compression, &jobs);
        if (image)
          jobs.push_back(
              [&dir, &opt, lv = &tr->levels, img, i] { write_view_image(dir, opt, *lv, i, img); });
        // Each file its own task: a thread that waits for them (the next view's wait, the run's
        // last) writes some of them itself instead of idling.
        for (auto& job : jobs) writer.run(std::move(job));
      }
      bar.advance();
    }
    wait_writer();
  } catch (...) {
    try {
      writer.wait();  // its buffers go with `tr`: let it finish first
    } catch (...) {
    }
    throw;
  }
  st->shadow_rays = shadow_rays;
  st->light_evals = light_evals;
}

void check_lit(double white_level) {
  if (!(white_level > 0))
    throw Error("capture_sim: every pixel is black (no light reaches the visible sample)");
}

std::string provenance(const SimOptions& opt, const SimStats& st, double white, bool fixed) {
  const jsonu::json gen = {{"tool", "aniso capture_sim"},
                           {"preset", opt.preset},
                           {"shape", opt.shape},
                           {"fiber_field", opt.fiber_field},
                           {"seed", opt.seed},
                           {"read_noise", opt.sensor.read_noise},
                           {"shot_photons", opt.sensor.shot_photons},
                           {"bits", opt.sensor.bits},
                           {"white_level", white},
                           {"mathematical_topology", math_topology_name(opt.mathematical_topology)},
                           {"counters",
                            {{"primary_rays", st.primary_rays},
                             {"shadow_rays", st.shadow_rays},
                             {"shaded_pixels", st.shaded_pixels},
                             {"light_evaluations", st.light_evals},
                             {"lights_culled", st.lights_culled},
                             {"geometry_traced_once", fixed}}}};
  return gen.dump();
}

// The set's header: camera, ambient, encoding and the stored value at which the sensor clips.
CaptureSet set_header(const SimOptions& opt, double saturation) {
  CaptureSet set;
  set.camera = opt.camera;
  set.ambient = opt.ambient;
  if (opt.sensor.encoding == "srgb") set.color.encoding = ColorSpec::Encoding::kSrgb;
  if (std::isfinite(saturation)) {
    // Stored values at or above this are clipped by the sensor and must not be used.
    set.color.saturation = opt.sensor.encoding == "srgb" ? srgb_encode(saturation) : saturation;
    set.color.saturation_given = true;
  }
  set.truth = "truth.json";
  return set;
}

// truth.json, with its maps (float EXR beside it) and the set's topology maps named.
void write_truth(const std::string& dir, const Material& truth, const std::string& topology_map,
                 bool s_map, ExrCompression c) {
  Material truth_m = truth;
  if (auto* t = truth_m.topology_as<TopologyMapRef>()) t->file = topology_map;
  if (s_map) truth_m.topology = SMapRef{"maps/topology_s.png"};
  MaterialMaps& mp = truth_m.maps;
  auto put = [&](const std::shared_ptr<const Image>& img, std::string* file, const char* name) {
    if (!img) return;
    *file = std::string("maps/truth_") + name + ".exr";
    write_exr(join_path(dir, *file), *img, c);
  };
  put(mp.kd, &mp.kd_file, "kd");
  put(mp.ks, &mp.ks_file, "ks");
  put(mp.n, &mp.n_file, "n");
  put(mp.fiber, &mp.fiber_file, "fiber");
  put(mp.amplitude, &mp.amplitude_file, "amplitude");
  jsonu::json j;
  material_to_json(truth_m, &j);
  write_json_file(join_path(dir, "truth.json"), j);
}

}  // namespace

SimStats simulate_capture(const SimOptions& opt, const std::string& out_dir) {
  const auto t0 = std::chrono::steady_clock::now();
  check_sim_options(opt);
  const bool is_obj = lower_ext(opt.shape) == ".obj";
  const TriMesh mesh = is_obj ? load_obj(opt.shape, opt.fiber_field.empty())
                              : make_shape(opt.shape, opt.shape_options);
  const RayScene scene(mesh);
  SimStats st;
  st.views = opt.rig.size();
  TopologyMap map;
  if (!opt.topology_map.empty()) map.h = quantised16(opt.topology_map);
  const Image s_map = quantised16(opt.s_map);

  if (!opt.write_files) {
    Traced tr;
    tr.images = Traced::Images::kMeasure;
    trace_and_shade(opt, scene, map, s_map, out_dir, &tr, &st);
    st.seconds = seconds_since(t0);
    return st;
  }
  write_folder_atomically(out_dir, OutputKind::kCapture, [&](const std::string& dir) {
    Traced tr;
    using Images = Traced::Images;
    const double kept = 12.0 * opt.camera.width * opt.camera.height * opt.rig.size();
    if (sensor_is_identity(opt.sensor)) {
      tr.images = Images::kWrite;  // the white level changes nothing: each view as it comes
    } else if (kept > opt.kept_radiance_bytes) {
      // Bounded memory: every view traced and shaded twice, the white level first.
      if (opt.progress) {
        char line[300];
        std::snprintf(line, sizeof line,
                      "capture_sim: keeping every view's radiance for the white level would take "
                      "%.3f GB (over the %.3f GB allowed, --kept-radiance-gb): the views are "
                      "shaded twice instead, the white level first",
                      kept / 1e9, opt.kept_radiance_bytes / 1e9);
        opt.progress->note(line);
      }
      Traced probe;
      probe.images = Images::kMeasure;
      probe.label = "capture_sim: the white level (pass 1 of 2)";
      tr.label = "capture_sim: tracing, shading and writing (pass 2 of 2)";
      SimStats first;
      trace_and_shade(opt, scene, map, s_map, dir, &probe, &first);
      st.passes = 2;
      check_lit(first.white_level);
      tr.images = Images::kWrite;
      tr.levels = sensor_levels(opt, first.white_level);
    }
    trace_and_shade(opt, scene, map, s_map, dir, &tr, &st);
    const auto t_write = std::chrono::steady_clock::now();
    check_lit(st.white_level);
    const SensorLevels lv = sensor_levels(opt, st.white_level);
    CaptureSet set = set_header(opt, lv.saturation);
    if (!map.h.empty()) {
      set.topology_map = "maps/topology.png";
      write_png(join_path(dir, set.topology_map), map.h, 16);
    }
    if (!s_map.empty()) write_png(join_path(dir, "maps/topology_s.png"), s_map, 16);
    if (tr.fixed_camera) set.geometry = tr.geometry[0];
    Progress bar("capture_sim: writing", opt.rig.size(), opt.progress);
    // Views are written in parallel; each has its own seeded generator, so the set is the same.
    set.views.resize(opt.rig.size());
    tbb::parallel_for(size_t(0), opt.rig.size(), [&](size_t i) {
      ViewSpec v;
      v.world_from_camera = opt.rig[i].world_from_camera;
      v.lights = opt.rig[i].lights;
      v.exposure = lv.exposure;
      v.camera = opt.camera;
      if (!tr.fixed_camera) v.geometry = tr.geometry[i];
      v.image = view_image_name(i, opt.sensor.bits);
      if (tr.images == Images::kKeep) write_view_image(dir, opt, lv, i, &tr.radiance[i]);
      set.views[i] = v;
      bar.advance();
    });
    write_truth(dir, opt.truth, set.topology_map, !s_map.empty(), opt.compression);
    set.provenance = provenance(opt, st, lv.white, tr.fixed_camera);
    write_capture_json(set, join_path(dir, "capture.json"));
    st.seconds_write += seconds_since(t_write);
  });
  st.seconds = seconds_since(t0);
  return st;
}

}  // namespace aniso
