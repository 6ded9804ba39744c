#include "bench/suites.h"

#include <embree3/rtcore.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "capture_sim/sim.h"
#include "core/angles.h"
#include "core/error.h"
#include "datasets_synth/presets.h"
#include "fit/fit.h"
#include "geometry/embree_device.h"
#include "geometry/mesh.h"
#include "io/capture.h"
#include "io/files.h"
#include "io/image_io.h"
#include "io/json_util.h"
#include "io/material_io.h"
#include "models/evaluate.h"
#include "models/fiber_model.h"
#include "models/fiber_reference.h"
#include "models/line_model.h"
#include "render/bake.h"
#include "render/preview.h"

namespace aniso {

namespace {

using jsonu::json;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

json entry(const std::string& suite, const std::string& name, double ours, double baseline,
           const std::string& unit, double error) {
  json e = {{"suite", suite}, {"name", name}, {"ours", ours}, {"unit", unit}};
  e["baseline"] = std::isfinite(baseline) ? json(baseline) : json(nullptr);
  e["ratio"] = std::isfinite(baseline) && ours != 0 ? json(baseline / ours) : json(nullptr);
  e["error"] = std::isfinite(error) ? json(error) : json(nullptr);
  return e;
}

void target(json* e, const std::string& what, bool met, const std::string& why_missed = "") {
  (*e)["target"] = what;
  (*e)["met"] = met;
  if (!met && !why_missed.empty()) (*e)["why_missed"] = why_missed;
}

// Peak resident memory (kB) of this process so far.
long peak_rss_kb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}
long current_rss_kb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}

struct Errs {
  double kd = 0, ks = 0, n = 0, psi = 0, topo = 0;
  double worst() const { return std::max({kd, ks, n, psi / 180.0}); }
};
Errs errors_of(const Material& m, const Material& t) {
  Errs e;
  for (int c = 0; c < 3; ++c) {
    e.kd = std::max(e.kd, std::abs(m.kd[c] - t.kd[c]) / t.kd[c]);
    e.ks = std::max(e.ks, std::abs(m.ks[c] - t.ks[c]) / t.ks[c]);
  }
  e.n = std::abs(m.n - t.n) / t.n;
  e.psi = fiber_deg_distance(m.fiber_angle_deg, t.fiber_angle_deg);
  e.topo = std::abs(m.uniform_s() - t.uniform_s());
  return e;
}

// ------------------------------------------------------------------------------------------------
json bench_fit(const std::string& work, bool quick) {
  json out = json::array();
  PresetOptions po;
  po.views = quick ? 6 : 16;
  po.width = po.height = quick ? 64 : 128;
  po.noise = 0.01;
  po.progress = false;
  const SimOptions so = make_preset("brushed-metal", po);
  const std::string dir = join_path(work, "fit_line");
  simulate_capture(so, dir);
  const CaptureSet set = read_capture(dir);
  std::vector<int> subs = quick ? std::vector<int>{4, 1} : std::vector<int>{8, 4, 2, 1};
  for (int sub : subs) {
    FitOptions fo;
    fo.progress = false;
    fo.subsample = sub;
    const FitResult r = fit_capture(set, fo);
    const Errs e = errors_of(r.material, so.truth);
    // SciPy least_squares on the same observations, from the same start.
    const std::string obs = join_path(work, "obs_" + std::to_string(sub) + ".bin");
    std::vector<double> start;
    const size_t rows = export_observations(set, fo, obs, &start);
    std::string cmd = "/usr/bin/python3 " + std::string(ANISO_SOURCE_DIR) + "/bench/scipy_fit.py " +
                      obs + " '" + json(start).dump() + "' 2>&1";
    double scipy_s = NAN, scipy_err = NAN;
    std::string outtxt;
    if (FILE* p = popen(cmd.c_str(), "r")) {
      char buf[4096];
      size_t n;
      while ((n = fread(buf, 1, sizeof buf, p)) > 0) outtxt.append(buf, n);
      pclose(p);
    }
    const json sj =
        json::parse(outtxt.substr(outtxt.find('{') == std::string::npos ? 0 : outtxt.find('{')),
                    nullptr, false);
    if (sj.is_object() && sj.contains("x")) {
      scipy_s = sj["seconds"].get<double>();
      Material sm = so.truth;
      const auto x = sj["x"].get<std::vector<double>>();
      for (int c = 0; c < 3; ++c) sm.kd[c] = x[c], sm.ks[c] = x[3 + c];
      sm.n = std::exp(x[6]);
      sm.fiber_angle_deg = wrap_fiber_deg(rad_to_deg(x[7]));
      scipy_err = errors_of(sm, so.truth).worst();
    }
    json e1 = entry("fit", "line fit vs SciPy least_squares, subsample " + std::to_string(sub),
                    r.report.seconds, scipy_s, "s", e.worst());
    e1["observations"] = r.report.observations;
    e1["pixels"] = rows;
    e1["baseline_error"] = std::isfinite(scipy_err) ? json(scipy_err) : json(nullptr);
    e1["error_definition"] = "worst of max relative error of kd, ks, n and psi error / 180 deg";
    e1["ours_breakdown_s"] = {{"load", r.report.seconds_load},
                              {"start", r.report.seconds_start},
                              {"solve", r.report.seconds_solve},
                              {"covariance", r.report.seconds_covariance}};
    e1["errors"] = {{"kd_rel", e.kd}, {"ks_rel", e.ks}, {"n_rel", e.n}, {"psi_deg", e.psi}};
    if (!std::isfinite(scipy_s)) e1["baseline_note"] = "SciPy run failed: " + outtxt.substr(0, 300);
    const bool met = std::isfinite(scipy_s) && scipy_s / r.report.seconds >= 30 &&
                     e.worst() <= scipy_err * 1.0001 + 1e-9;
    target(&e1, ">= 30x less wall time than SciPy at equal or better error", met,
           "SciPy's 2-point Jacobian is vectorised numpy; the ratio is what was measured");
    e1["us_per_observation"] = 1e6 * r.report.seconds / r.report.observations;
    out.push_back(e1);
    // The solver alone (both start from the same grid point with the data in memory).
    const double ours_solve = r.report.seconds_solve;
    json e2 =
        entry("fit", "line solve vs SciPy least_squares solve, subsample " + std::to_string(sub),
              ours_solve, scipy_s, "s", e.worst());
    e2["observations"] = r.report.observations;
    e2["baseline_error"] = e1["baseline_error"];
    target(&e2, ">= 30x less wall time than SciPy at equal or better error",
           std::isfinite(scipy_s) && scipy_s / ours_solve >= 30 &&
               e.worst() <= scipy_err * 1.0001 + 1e-9,
           "both solvers take a handful of iterations; SciPy's per-iteration cost is vectorised "
           "numpy, ours is "
           "Ceres with analytic derivatives: the gap is a small constant, not 30x");
    out.push_back(e2);
    std::printf(
        "bench fit: subsample %d: %zu obs, ours %.3f s total / %.3f s solve (err %.2e), SciPy %.3f "
        "s solve (err "
        "%.2e), ratios %.2f / %.2f\n",
        sub, r.report.observations, r.report.seconds, r.report.seconds_solve, e.worst(), scipy_s,
        scipy_err, scipy_s / r.report.seconds, scipy_s / r.report.seconds_solve);
  }
  // Linearity: time per observation across the sweep.
  // Peak memory of a full-resolution fit, measured in a child process.
  {
    int fds[2];
    if (pipe(fds) == 0) {
      const pid_t pid = fork();
      if (pid == 0) {
        close(fds[0]);
        const long before = current_rss_kb();
        FitOptions fo;
        fo.progress = false;
        const FitResult r = fit_capture(set, fo);
        const long peak = peak_rss_kb();
        char buf[128];
        const int n = std::snprintf(buf, sizeof buf, "%ld %ld %zu", before, peak, r.report.pixels);
        if (write(fds[1], buf, n) < 0) _exit(1);
        _exit(0);
      }
      close(fds[1]);
      char buf[128] = {0};
      const ssize_t n = read(fds[0], buf, sizeof buf - 1);
      close(fds[0]);
      int status = 0;
      waitpid(pid, &status, 0);
      long before = 0, peak = 0;
      size_t pixels = 0;
      if (n > 0 && std::sscanf(buf, "%ld %ld %zu", &before, &peak, &pixels) == 3) {
        // The observations' own size: per pixel the record of the export format (14 float64:
        // view and light directions, irradiance, the three values, topology).
        const double own_kb = pixels * 14 * 8 / 1024.0;
        json e = entry("fit", "peak memory of a full fit over the observations' own size",
                       (peak - before) / own_kb, NAN, "ratio", NAN);
        e["peak_kb_above_start"] = peak - before;
        e["observations_kb"] = own_kb;
        target(&e, "<= 2x the observations' own size", (peak - before) <= 2 * own_kb,
               "one Ceres residual block per pixel (cost function, Jacobian storage and "
               "bookkeeping) and the loaded "
               "EXR images of every view dominate; batching pixels into larger blocks is the fix");
        out.push_back(e);
        std::printf(
            "bench fit: peak memory %.1f x the observations' own size (%ld kB above start, %.0f kB "
            "own)\n",
            (peak - before) / own_kb, peak - before, own_kb);
      }
    }
  }
  // The fiber model's fit: observations against time and error.
  {
    PresetOptions pf = po;
    pf.noise = 0.0;
    const SimOptions sf = make_preset("fiber-flat", pf);
    const std::string fdir = join_path(work, "fit_fiber");
    simulate_capture(sf, fdir);
    const CaptureSet fs = read_capture(fdir);
    for (int sub : quick ? std::vector<int>{4} : std::vector<int>{8, 4, 2, 1}) {
      FitOptions fo;
      fo.progress = false;
      fo.model = FitModel::kFiber;
      fo.subsample = sub;
      const FitResult r = fit_capture(fs, fo);
      const Errs e = errors_of(r.material, sf.truth);
      json ef = entry("fit", "fiber fit, subsample " + std::to_string(sub), r.report.seconds, NAN,
                      "s", e.worst());
      ef["observations"] = r.report.observations;
      ef["errors"] = {{"kd_rel", e.kd},
                      {"ks_rel", e.ks},
                      {"n_rel", e.n},
                      {"psi_deg", e.psi},
                      {"s_abs", e.topo}};
      ef["us_per_observation"] = 1e6 * r.report.seconds / r.report.observations;
      out.push_back(ef);
      std::printf("bench fit: fiber subsample %d: %zu obs, %.3f s, worst error %.2e, |ds| %.2e\n",
                  sub, r.report.observations, r.report.seconds, e.worst(), e.topo);
    }
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
json bench_fiber(bool quick) {
  json out = json::array();
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  struct Case {
    double lb, ln, vb, vn, a, b;
  };
  std::vector<Case> cases;
  const int ncases = quick ? 200 : 2000;
  for (int i = 0; i < ncases; ++i) {
    auto unit = [&]() {
      const double x = g(rng), y = g(rng), z = std::abs(g(rng)),
                   l = std::sqrt(x * x + y * y + z * z);
      return std::array<double, 3>{x / l, y / l, z / l};
    };
    const auto L = unit(), V = unit();
    cases.push_back({L[1], L[2], V[1], V[2], L[0], V[0]});
  }
  for (double n : {10.0, 100.0, 1000.0}) {
    std::vector<double> ref(cases.size());
    for (size_t i = 0; i < cases.size(); ++i) {
      double D;
      const Case& c = cases[i];
      fiber_DS(c.lb, c.ln, c.vb, c.vn, c.a, c.b, n, 0.5, FiberAccuracy{32}, &D, &ref[i]);
    }
    // Brute force: time per evaluation and its error at 24000 samples per fiber (a subset).
    const size_t nb = quick ? 5 : 40;
    double brute_err = 0;
    const auto tb = Clock::now();
    for (size_t i = 0; i < nb; ++i) {
      const Case& c = cases[i];
      const auto r = reference::fiber_bruteforce(c.lb, c.ln, c.vb, c.vn, c.a, c.b, n, 0.5, 24000);
      brute_err = std::max(brute_err, std::abs(r.S - ref[i]) / std::max(ref[i], 1e-3));
    }
    const double brute_ns = 1e9 * since(tb) / nb;
    for (int order : {2, 3, 4, 6, 8, 12, 16}) {
      double err = 0, sink = 0;
      const int reps = quick ? 1 : 5;
      const auto t0 = Clock::now();
      for (int rep = 0; rep < reps; ++rep)
        for (size_t i = 0; i < cases.size(); ++i) {
          const Case& c = cases[i];
          double D, S;
          fiber_DS(c.lb, c.ln, c.vb, c.vn, c.a, c.b, n, 0.5, FiberAccuracy{order}, &D, &S);
          sink += S;
          if (rep == 0) err = std::max(err, std::abs(S - ref[i]) / std::max(ref[i], 1e-3));
        }
      const double ns = 1e9 * since(t0) / (reps * cases.size());
      json e = entry("fiber",
                     "fiber model order " + std::to_string(order) + ", n=" + std::to_string(int(n)),
                     ns, brute_ns, "ns/eval", err);
      e["error_definition"] =
          "max |S - S_order32| / max(S_order32, 1e-3) over random directions, s = 0.5";
      e["baseline_error"] = brute_err;
      e["baseline"] = brute_ns;
      e["baseline_note"] = "brute force, 24000 normal samples per fiber, ray-circle tests";
      target(&e, ">= 100x faster than brute force at relative error <= 1e-4",
             brute_ns / ns >= 100 && err <= 1e-4,
             err > 1e-4 ? "this order is below the accuracy target; higher orders meet it" : "");
      e["checksum"] = sink;
      out.push_back(e);
    }
    std::printf(
        "bench fiber: n=%g: brute force %.0f us/eval (its error %.1e); see the orders in the "
        "output\n",
        n, brute_ns / 1e3, brute_err);
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
json bench_bake(bool quick) {
  json out = json::array();
  for (double n : {10.0, 100.0, 1000.0, 10000.0}) {
    Material m;
    m.kd = {0.2, 0.2, 0.2};
    m.ks = {0.6, 0.6, 0.6};
    m.n = n;
    for (int size :
         quick ? std::vector<int>{64, 256} : std::vector<int>{64, 128, 256, 512, 1024, 2048})
      for (BakeIndex index : {BakeIndex::kAngle, BakeIndex::kCosine}) {
        const BakeTables t = bake_line(m, size, index);
        // Quantisation: PNG stores value / peak in 2^bits - 1 steps.
        json e = entry("bake",
                       std::string("bake ") + index_name(index) + " " + std::to_string(size) +
                           "^2 n=" + std::to_string(int(n)),
                       t.seconds, NAN, "s", t.max_abs_error);
        e["rms_error"] = t.rms_error;
        e["peak_value"] = t.peak_value;
        e["size"] = size;
        e["n"] = n;
        e["index"] = index_name(index);
        e["png16_extra_error"] = 0.5 * t.peak_value / 65535.0;
        e["png8_extra_error"] = 0.5 * t.peak_value / 255.0;
        if (size == 256 && index == BakeIndex::kAngle)
          target(&e, "256^2 float table well under a second", t.seconds < 0.1);
        out.push_back(e);
      }
  }
  // Angle against cosine index at equal size: the error ratio.
  for (auto& e : out)
    if (e["index"] == "angle")
      for (const auto& c : out)
        if (c["index"] == "cosine" && c["size"] == e["size"] && c["n"] == e["n"]) {
          e["baseline"] = c["error"];
          e["baseline_note"] =
              "the paper's cosine-spaced table: its max error (ratio = error reduction)";
          e["ratio"] = e["error"].get<double>() > 0
                           ? c["error"].get<double>() / e["error"].get<double>()
                           : 0.0;
        }
  std::printf("bench bake: %zu table configurations\n", out.size());
  return out;
}

// ------------------------------------------------------------------------------------------------
// A bare Embree loop over the same scene: the primary rays of every view and one shadow ray per
// front-facing hit, no shading, no I/O.
double bare_embree_rays_per_s(const TriMesh& mesh, const SimOptions& so, size_t* rays_out) {
  RTCDevice dev = new_embree_device("bench (bare Embree loop)");
  RTCScene scene = rtcNewScene(dev);
  RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.P.size()));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.tri.size()));
  for (size_t i = 0; i < mesh.P.size(); ++i)
    for (int k = 0; k < 3; ++k) vb[3 * i + k] = static_cast<float>(mesh.P[i][k]);
  for (size_t i = 0; i < mesh.tri.size(); ++i)
    for (int k = 0; k < 3; ++k) ib[3 * i + k] = mesh.tri[i][k];
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  std::atomic<size_t> rays{0};
  const auto t0 = Clock::now();
  const Intrinsics& k = so.camera;
  for (const RigView& v : so.rig) {
    const Vec3 eye = v.world_from_camera.translation();
    const Vec3 lp = v.lights[0].position;
    tbb::parallel_for(tbb::blocked_range<int>(0, k.height), [&](const tbb::blocked_range<int>& r) {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      size_t local = 0;
      for (int y = r.begin(); y < r.end(); ++y)
        for (int x = 0; x < k.width; ++x) {
          const Vec3 d =
              normalize(v.world_from_camera.dir(Vec3((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0)));
          RTCRayHit rh;
          rh.ray.org_x = float(eye.x), rh.ray.org_y = float(eye.y), rh.ray.org_z = float(eye.z);
          rh.ray.dir_x = float(d.x), rh.ray.dir_y = float(d.y), rh.ray.dir_z = float(d.z);
          rh.ray.tnear = 0, rh.ray.tfar = INFINITY, rh.ray.mask = ~0u, rh.ray.time = 0,
          rh.ray.flags = 0;
          rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
          rtcIntersect1(scene, &ctx, &rh);
          ++local;
          if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID || !mesh.can_self_shadow) continue;
          const Vec3 p = eye + d * double(rh.ray.tfar);
          const Vec3 L = normalize(lp - p);
          RTCRay sr;
          sr.org_x = float(p.x + 1e-4 * L.x), sr.org_y = float(p.y + 1e-4 * L.y),
          sr.org_z = float(p.z + 1e-4 * L.z);
          sr.dir_x = float(L.x), sr.dir_y = float(L.y), sr.dir_z = float(L.z);
          sr.tnear = 0, sr.tfar = float(length(lp - p)), sr.mask = ~0u, sr.time = 0, sr.flags = 0;
          rtcOccluded1(scene, &ctx, &sr);
          ++local;
        }
      rays += local;
    });
  }
  const double dt = since(t0);
  rtcReleaseScene(scene);
  rtcReleaseDevice(dev);
  *rays_out = rays;
  return rays / dt;
}

json bench_capture(const std::string& work, bool quick) {
  json out = json::array();
  for (const char* shape : {"sphere", "torus"}) {
    PresetOptions po;
    po.views = quick ? 4 : 16;
    po.width = po.height = quick ? 96 : 256;
    po.progress = false;
    SimOptions so = make_preset("brushed-metal", po);
    so.shape = shape;
    so.shape_options.torus_r = 0.6;
    so.camera = frame_camera(po.width, po.height, 1.6, 4.0);
    so.rig = rig_orbit(po.views, 4.0);  // a moving camera: every view traced
    set_exr_compression("none");        // the synth default
    const SimStats st = simulate_capture(so, join_path(work, std::string("capture_") + shape));
    const double ours = (st.primary_rays + st.shadow_rays) / st.seconds;
    size_t bare_rays = 0;
    const double bare = bare_embree_rays_per_s(make_shape(shape, so.shape_options), so, &bare_rays);
    json e = entry(
        "capture",
        std::string("capture_sim rays/s (tracing, shading, noise, EXR writing) vs bare Embree, ") +
            shape,
        ours, bare, "rays/s", NAN);
    e["ratio"] = ours / bare;  // ours relative to the bare loop (target >= 0.6)
    e["ratio_definition"] = "ours / baseline";
    e["rays"] = st.primary_rays + st.shadow_rays;
    e["bare_rays"] = bare_rays;
    e["seconds"] = st.seconds;
    e["seconds_breakdown"] = {
        {"trace", st.seconds_trace},
        {"shade", st.seconds_shade},
        {"write", st.seconds_write},
        {"other", st.seconds - st.seconds_trace - st.seconds_shade - st.seconds_write}};
    target(&e, ">= 0.6x the bare Embree loop's rays per second", ours / bare >= 0.6,
           "shading, sensor noise and EXR compression/writing cost more than 40 % of a bare ray "
           "loop at this size");
    out.push_back(e);
    std::printf("bench capture: %s: ours %.2f Mrays/s, bare Embree %.2f Mrays/s, ratio %.2f\n",
                shape, ours / 1e6, bare / 1e6, ours / bare);
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
json bench_preview(bool quick) {
  json out = json::array();
  Material m;
  m.kd = {0.25, 0.1, 0.05};
  m.ks = {0.6, 0.55, 0.5};
  m.n = 60;
  m.fiber_angle_deg = 20;
  for (const char* shape : {"sphere", "torus"}) {
    PreviewOptions p;
    p.shape = shape;
    p.width = p.height = quick ? 256 : 1024;
    p.repeat = quick ? 3 : 20;
    p.shape_options.resolution = 512;  // ~260k triangles: vertex-heavy enough to show the cost
    PreviewOptions plain = p, paper = p;
    plain.plain = true;
    paper.per_vertex = true;
    // Warm the programs once, then measure.
    render_preview(m, p);
    const PreviewResult ra = render_preview(m, p);
    const PreviewResult rp = render_preview(m, plain);
    const PreviewResult rq = render_preview(m, paper);
    json eq = entry(
        "preview",
        std::string(
            "paper's construction (per-vertex texture matrix, cosine table) vs plain pass, ") +
            shape,
        1e3 * rq.seconds_per_frame, 1e3 * rp.seconds_per_frame, "ms/frame", NAN);
    eq["ratio"] = rq.seconds_per_frame / rp.seconds_per_frame;
    eq["ratio_definition"] = "ours / baseline";
    target(&eq, "anisotropic pass <= 1.05x the plain pass",
           rq.seconds_per_frame <= 1.05 * rp.seconds_per_frame,
           "llvmpipe shades in software: the second lookup is not free");
    out.push_back(eq);
    std::printf("bench preview: %s: paper-exact pass %.2f ms vs plain %.2f ms, ratio %.3f\n", shape,
                1e3 * rq.seconds_per_frame, 1e3 * rp.seconds_per_frame,
                rq.seconds_per_frame / rp.seconds_per_frame);
    json e =
        entry("preview", std::string("anisotropic pass vs plain textured-and-lit pass, ") + shape,
              1e3 * ra.seconds_per_frame, 1e3 * rp.seconds_per_frame, "ms/frame", NAN);
    e["ratio"] = ra.seconds_per_frame / rp.seconds_per_frame;
    e["ratio_definition"] = "ours / baseline";
    e["renderer"] = ra.renderer;
    e["triangles"] = ra.triangles;
    e["pixels"] = p.width * p.height;
    target(&e, "anisotropic pass <= 1.05x the plain pass",
           ra.seconds_per_frame <= 1.05 * rp.seconds_per_frame,
           "on llvmpipe (CPU rasteriser) per-fragment work is not free: the acos of the angle "
           "index, normalisation "
           "and two lookups cost more than one lookup and a dot product");
    out.push_back(e);
    std::printf("bench preview: %s on %s: aniso %.2f ms, plain %.2f ms, ratio %.3f\n", shape,
                ra.renderer.c_str(), 1e3 * ra.seconds_per_frame, 1e3 * rp.seconds_per_frame,
                ra.seconds_per_frame / rp.seconds_per_frame);
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
json bench_skips(const std::string& work, bool quick) {
  json out = json::array();
  PresetOptions po;
  po.views = quick ? 4 : 16;
  po.width = po.height = quick ? 96 : 256;
  po.progress = false;
  // Shadow rays for a shape that cannot shadow itself (sphere).
  {
    SimOptions so = make_preset("satin-ball", po);
    const SimStats skip = simulate_capture(so, join_path(work, "skip_a"));
    so.force_shadows = true;
    const SimStats all = simulate_capture(so, join_path(work, "skip_b"));
    json e = entry("skips", "no shadow rays for a convex shape (sphere): shading time",
                   skip.seconds_shade, all.seconds_shade, "s", NAN);
    e["shadow_rays_skipped"] = all.shadow_rays;
    out.push_back(e);
    std::printf(
        "bench skips: shadow rays: shading %.3f s with the skip, %.3f s without (%zu rays)\n",
        skip.seconds_shade, all.seconds_shade, all.shadow_rays);
  }
  // Geometry of a fixed camera traced once.
  {
    SimOptions so = make_preset("brushed-metal", po);
    const SimStats skip = simulate_capture(so, join_path(work, "skip_c"));
    so.force_retrace = true;
    const SimStats all = simulate_capture(so, join_path(work, "skip_d"));
    json e = entry("skips", "fixed camera: geometry traced once, not per view: tracing time",
                   skip.seconds_trace, all.seconds_trace, "s", NAN);
    e["primary_rays"] = {{"ours", skip.primary_rays}, {"baseline", all.primary_rays}};
    out.push_back(e);
    std::printf("bench skips: geometry once: tracing %.3f s vs %.3f s (%zu vs %zu primary rays)\n",
                skip.seconds_trace, all.seconds_trace, skip.primary_rays, all.primary_rays);
  }
  // Zero-weight terms: the line model with an isotropic block of zero weights.
  {
    Material a;
    a.kd = {0.2, 0.2, 0.2};
    a.ks = {0.5, 0.5, 0.5};
    Material b = a;
    b.has_isotropic = true;
    b.iso_n = 20;
    LineParamsT<double> pa = line_params(a), pb = line_params(b);
    pb.isotropic = true;  // evaluate the zero-weight term anyway
    std::mt19937_64 rng(3);
    std::normal_distribution<double> g;
    std::vector<LocalDir> dirs;
    for (int i = 0; i < 200000; ++i) {
      const double x = g(rng), y = g(rng), z = std::abs(g(rng)),
                   l = std::sqrt(x * x + y * y + z * z);
      dirs.push_back({x / l, y / l, z / l});
    }
    double sink = 0;
    auto time = [&](const LineParamsT<double>& p) {
      const auto t0 = Clock::now();
      for (size_t i = 0; i + 1 < dirs.size(); ++i) {
        double f[3];
        line_reflectance(p, dirs[i], dirs[i + 1], f);
        sink += f[0];
      }
      return 1e9 * since(t0) / (dirs.size() - 1);
    };
    time(pa);
    const double ta = time(pa), tb = time(pb);
    json e =
        entry("skips", "zero-weight isotropic term skipped in the model", ta, tb, "ns/eval", NAN);
    e["checksum"] = sink;
    out.push_back(e);
    std::printf("bench skips: zero-weight term: %.1f ns vs %.1f ns per evaluation\n", ta, tb);
  }
  return out;
}

}  // namespace

void run_bench(const std::string& suite, const std::string& out_path, const std::string& work_dir,
               bool quick) {
  static const char* kSuites[] = {"fit", "fiber", "bake", "capture", "preview", "skips", "all"};
  bool known = false;
  for (const char* s : kSuites) known |= suite == s;
  if (!known)
    throw Error("bench: unknown suite '" + suite +
                "' (fit, fiber, bake, capture, preview, skips, all)");
  std::filesystem::create_directories(work_dir);
  json entries = json::array();
  auto add = [&](const json& a) {
    for (const auto& e : a) entries.push_back(e);
  };
  const auto t0 = Clock::now();
  if (suite == "fit" || suite == "all") add(bench_fit(work_dir, quick));
  if (suite == "fiber" || suite == "all") add(bench_fiber(quick));
  if (suite == "bake" || suite == "all") add(bench_bake(quick));
  if (suite == "capture" || suite == "all") add(bench_capture(work_dir, quick));
  if (suite == "preview" || suite == "all") add(bench_preview(quick));
  if (suite == "skips" || suite == "all") add(bench_skips(work_dir, quick));
  json doc = {{"format", "aniso-bench"},
              {"version", 1},
              {"suite", suite},
              {"quick", quick},
              {"machine", {{"hardware_threads", std::thread::hardware_concurrency()}}},
              {"seconds", since(t0)},
              {"entries", entries}};
  write_json_file(out_path, doc);
  size_t met = 0, missed = 0;
  for (const auto& e : entries)
    if (e.contains("met")) (e["met"].get<bool>() ? met : missed)++;
  std::printf("bench %s: %zu entries, targets met %zu, missed %zu -> %s (%.1f s)\n", suite.c_str(),
              entries.size(), met, missed, out_path.c_str(), since(t0));
}

}  // namespace aniso
