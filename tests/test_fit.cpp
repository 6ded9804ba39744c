// fit: recovery on synthetic ground truth (the stated limits), calibrated uncertainties, every
// input form (EXR buffers, sRGB PNG, OBJ mesh, sample table), ill-posed data named as such.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "core/error.h"
#include "core/progress.h"
#include "datasets_synth/presets.h"
#include "fit/fit.h"
#include "fit/solvers/isotropic_pixel.h"
#include "fit/solvers/line_pixel_lanes.h"
#include "fit/solvers/model_fit.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "models/evaluate.h"
#include "models/material_maps.h"
#include "test_util.h"

namespace aniso {
namespace {

PresetOptions small(int views = 8, int size = 64) {
  PresetOptions p;
  p.views = views;
  p.width = p.height = size;
  p.progress = nullptr;
  return p;
}

FitOptions quiet() {
  FitOptions f;
  f.progress = nullptr;
  return f;
}

TruthErrors fit_and_compare(const std::string& dir, const Material& truth,
                            const FitOptions& fo = quiet(), FitResult* out = nullptr) {
  const FitResult r = fit_capture(read_capture(dir), fo);
  TruthErrors e;
  const std::string table = compare_to_truth(r, truth, &e);
  std::cout << table;
  if (out) *out = r;
  return e;
}

void expect_noise_free_limits(const TruthErrors& e) {
  EXPECT_LT(e.kd_rel, 0.005);
  EXPECT_LT(e.ks_rel, 0.005);
  EXPECT_LT(e.n_rel, 0.01);
  EXPECT_LT(e.psi_deg, 0.2);
}

TEST(FitRecovery, NoiseFreeBrushedMetal) {
  const std::string dir = test::tmp_dir("set");
  const SimOptions so = make_preset("brushed-metal", small());
  simulate_capture(so, dir);
  expect_noise_free_limits(fit_and_compare(dir, so.truth));
}

TEST(FitRecovery, NoiseFreeCurvedObjectsWithFiberFields) {
  for (const char* preset : {"satin-ball", "cd", "radial-disc"}) {
    const std::string dir = test::tmp_dir(preset);
    const SimOptions so = make_preset(preset, small());
    simulate_capture(so, dir);
    FitResult r;
    expect_noise_free_limits(fit_and_compare(dir, so.truth, quiet(), &r));
    // The sphere's far side is unlit in some views: the loader closes those gaps in its arrays
    // (fit/records/observations.cpp), and a record paired with another pixel's light would not fit.
    if (std::string(preset) == "satin-ball") {
      EXPECT_GT(r.report.unlit, 1000u);
    }
  }
}

TEST(FitRecovery, RandomMaterialsFromDeterministicStart) {
  for (uint64_t seed : {11u, 12u, 13u}) {
    PresetOptions p = small();
    p.seed = seed;
    const std::string dir = test::tmp_dir("random" + std::to_string(seed));
    const SimOptions so = make_preset("random", p);
    simulate_capture(so, dir);
    expect_noise_free_limits(fit_and_compare(dir, so.truth));
  }
}

// With 1 % read noise every parameter lands within 4 of its reported standard deviations, and at
// most one of the twelve (three seeds; k_d and k_s as their worst channel) beyond 3. A calibrated
// sigma fails this about 0.3 % of the time; a sigma half as large as it should be, nearly always.
// (60 seeds: k_d's worst channel had a median of 1.33 sigma, 1.26 expected; one beyond 3, 3.27.)
TEST(FitRecovery, OnePercentNoiseWithinThreeReportedSigma) {
  int beyond3 = 0;
  for (uint64_t seed : {1u, 2u, 3u}) {
    PresetOptions p = small(12, 64);
    p.noise = 0.01;
    p.seed = seed;
    const std::string dir = test::tmp_dir("noisy" + std::to_string(seed));
    const SimOptions so = make_preset("brushed-metal", p);
    simulate_capture(so, dir);
    FitResult r;
    const TruthErrors e = fit_and_compare(dir, so.truth, quiet(), &r);
    for (const double z : {e.kd_sigmas, e.ks_sigmas, e.n_sigmas, e.psi_sigmas}) {
      EXPECT_LE(z, 4.0) << "seed " << seed;
      beyond3 += z > 3.0;
    }
    EXPECT_TRUE(r.undetermined.empty());
    EXPECT_NEAR(r.report.rms, 0.01 * 1.0, 0.01);  // residual at the noise level
  }
  EXPECT_LE(beyond3, 1);
}

TEST(FitRecovery, Srgb16BitPngCapture) {
  const std::string dir = test::tmp_dir("png");
  PresetOptions p = small();
  p.bits = 16;
  p.encoding = "srgb";
  const SimOptions so = make_preset("brushed-metal", p);
  simulate_capture(so, dir);
  expect_noise_free_limits(fit_and_compare(dir, so.truth));
}

TEST(FitRecovery, MeshGeometryCapture) {
  const std::string dir = test::tmp_dir("mesh");
  const std::string obj = dir + "/square.obj";
  std::ofstream(obj) << "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                        "vn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";
  SimOptions so = make_preset("brushed-metal", small());
  so.shape = obj;
  simulate_capture(so, dir + "/set");
  // Replace the per-pixel buffers by the mesh: the fitter casts the camera rays itself.
  nlohmann::json j = nlohmann::json::parse(read_text_file(dir + "/set/capture.json"));
  j["geometry"] = {{"mesh", "../square.obj"}};
  write_text_file(dir + "/set/capture.json", j.dump());
  std::filesystem::remove_all(dir + "/set/geometry");
  expect_noise_free_limits(fit_and_compare(dir + "/set", so.truth));
}

TEST(FitRecovery, WovenClothSecondFiber) {
  const std::string dir = test::tmp_dir("cloth");
  const SimOptions so = make_preset("woven-cloth", small(16));
  simulate_capture(so, dir);
  FitOptions fo = quiet();
  fo.fit_second = true;
  FitResult r;
  fit_and_compare(dir, so.truth, fo, &r);
  // The two lobes may come back swapped (psi <-> psi2, w <-> 1 - w): the same material.
  Material m = r.material;
  if (std::abs(m.second_weight - so.truth.second_weight) > 0.1) {
    std::swap(m.fiber_angle_deg, m.second_angle_deg);
    m.second_weight = 1 - m.second_weight;
  }
  auto angdiff = [](double a, double b) {
    double d = std::fmod(std::abs(a - b), 180.0);
    return std::min(d, 180 - d);
  };
  EXPECT_LT(angdiff(m.fiber_angle_deg, so.truth.fiber_angle_deg), 0.2);
  EXPECT_LT(angdiff(m.second_angle_deg, so.truth.second_angle_deg), 0.2);
  EXPECT_NEAR(m.second_weight, so.truth.second_weight, 0.005);
  EXPECT_NEAR(m.n, so.truth.n, 0.01 * so.truth.n);
}

TEST(FitRecovery, SampleTableFromEvaluatedMaterial) {
  Material truth;
  truth.kd = {0.3, 0.2, 0.1};
  truth.ks = {0.4, 0.5, 0.6};
  truth.n = 80;
  truth.fiber_angle_deg = 140;
  const Evaluator ev(truth);
  SampleTable t;
  t.values = SampleTable::Values::kRGB;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> th(0, 80), ph(0, 360);
  for (int i = 0; i < 3000; ++i) {
    SampleRow r{th(rng), ph(rng), th(rng), ph(rng)};
    double f[3];
    ev(dir_from_angles(r.theta_i, r.phi_i), dir_from_angles(r.theta_o, r.phi_o), f);
    r.value = {f[0], f[1], f[2]};
    t.rows.push_back(r);
  }
  const FitResult r = fit_table(t, quiet());
  TruthErrors e;
  std::cout << compare_to_truth(r, truth, &e);
  expect_noise_free_limits(e);
}

// k_s = 0: no lobe, so n cannot be measured; the fit must say so instead of a confident number.
TEST(FitIllPosed, NoSpecularLobeLeavesNUndetermined) {
  const std::string dir = test::tmp_dir("matte");
  SimOptions so = make_preset("brushed-metal", small());
  so.truth.ks = {0, 0, 0};
  simulate_capture(so, dir);
  const FitResult r = fit_capture(read_capture(dir), quiet());
  EXPECT_EQ(r.undetermined.count("n"), 1u);
  EXPECT_EQ(r.sigma.count("n"), 0u);
  EXPECT_NEAR(r.material.kd[0], so.truth.kd[0], 0.005 * so.truth.kd[0]);
  write_fit(dir + "/m.json", r);
  const auto j = nlohmann::json::parse(read_text_file(dir + "/m.json"));
  EXPECT_TRUE(j["uncertainty"]["n"].is_null());
  EXPECT_TRUE(j["undetermined"].contains("n"));
}

// Outliers (hot pixels) pull a plain least-squares fit; the robust loss ignores them.
TEST(FitRobust, HuberLossResistsHotPixels) {
  const std::string dir = test::tmp_dir("hot");
  PresetOptions p = small(8, 64);
  p.noise = 0.005;
  const SimOptions so = make_preset("brushed-metal", p);
  simulate_capture(so, dir);
  std::mt19937_64 rng(9);
  for (int v = 0; v < 8; ++v) {
    const std::string name = dir + "/images/00" + std::to_string(v) + ".exr";
    Image img = read_image(name).image;
    std::uniform_int_distribution<size_t> pick(0, img.px.size() - 1);
    for (int k = 0; k < 40; ++k) img.px[pick(rng)] = 5.0f;
    write_exr(name, img);
  }
  FitOptions plain = quiet();
  plain.loss = FitLoss::kNone;
  const TruthErrors e_plain = fit_and_compare(dir, so.truth, plain);
  const TruthErrors e_huber = fit_and_compare(dir, so.truth, quiet());
  EXPECT_LT(e_huber.kd_rel, 0.5 * e_plain.kd_rel);
  EXPECT_LT(e_huber.kd_rel, 0.01);
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// Issue 3's limits (noise-free): k_d, k_s within 1 %, n within 2 %, psi within 0.5 deg,
// s within 0.01, A within 0.02.
void expect_fiber_limits(const TruthErrors& e) {
  EXPECT_LT(e.kd_rel, 0.01);
  EXPECT_LT(e.ks_rel, 0.01);
  EXPECT_LT(e.n_rel, 0.02);
  EXPECT_LT(e.psi_deg, 0.5);
  EXPECT_LT(e.topo_abs, 0.02);
}

TEST(FitFiber, FlatSamplesAcrossTopology) {
  for (double s : {0.15, 0.5, 0.85}) {
    PresetOptions p = small(10, 64);
    p.topology_s = s;
    const std::string dir = test::tmp_dir("flat" + std::to_string(s));
    const SimOptions so = make_preset("fiber-flat", p);
    simulate_capture(so, dir);
    FitOptions fo = quiet();
    fo.model = FitModel::kFiber;
    FitResult r;
    const TruthErrors e = fit_and_compare(dir, so.truth, fo, &r);
    expect_fiber_limits(e);
    EXPECT_LT(e.topo_abs, 0.01);
    EXPECT_EQ(r.material.model, Model::kFiber);
  }
}

TEST(FitFiber, TorusWithTopologyMapRecoversAmplitude) {
  const std::string dir = test::tmp_dir("torus");
  PresetOptions p = small(10, 80);
  p.topology_amplitude = 0.3;
  const SimOptions so = make_preset("silk-torus", p);
  simulate_capture(so, dir);
  FitOptions fo = quiet();
  fo.model = FitModel::kFiber;
  FitResult r;
  const TruthErrors e = fit_and_compare(dir, so.truth, fo, &r);
  expect_fiber_limits(e);
  ASSERT_NE(r.material.topology_as<TopologyMapRef>(), nullptr);
  EXPECT_EQ(r.material.mathematical(), MathTopology::kTorus);
}

TEST(FitFiber, AutoChoosesTheModelThatMadeTheData) {
  for (const char* preset : {"fiber-flat", "brushed-metal"}) {
    PresetOptions p = small(6, 48);
    p.noise = 0.01;
    const std::string dir = test::tmp_dir(preset);
    const SimOptions so = make_preset(preset, p);
    simulate_capture(so, dir);
    FitOptions fo = quiet();
    fo.model = FitModel::kAuto;
    const FitResult r = fit_capture(read_capture(dir), fo);
    EXPECT_EQ(r.material.model, so.truth.model) << r.report.model_selection;
    EXPECT_NE(r.report.model_selection.find(std::string("chose ") + model_name(so.truth.model)),
              std::string::npos);
  }
}

TEST(FitFiber, SampleTableWithTopologyColumn) {
  Material truth;
  truth.model = Model::kFiber;
  truth.kd = {0.2, 0.25, 0.3};
  truth.ks = {0.5, 0.4, 0.3};
  truth.n = 20;
  truth.fiber_angle_deg = 60;
  const Evaluator ev(truth);
  SampleTable t;
  t.values = SampleTable::Values::kRGB;
  t.has_s = true;
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> th(0, 80), ph(0, 360), u(0, 1);
  for (int i = 0; i < 1500; ++i) {
    SampleRow r{th(rng), ph(rng), th(rng), ph(rng)};
    r.s = u(rng);
    double f[3];
    ev(dir_from_angles(r.theta_i, r.phi_i), dir_from_angles(r.theta_o, r.phi_o), f, r.s);
    r.value = {f[0], f[1], f[2]};
    t.rows.push_back(r);
  }
  FitOptions fo = quiet();
  fo.model = FitModel::kFiber;
  const FitResult r = fit_table(t, fo);
  TruthErrors e;
  std::cout << compare_to_truth(r, truth, &e);
  expect_fiber_limits(e);
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// The largest |a - b| / sigma over k_d, k_s, n and psi of two fits, each checked under `limit`.
double worst_in_sigma(const FitResult& ra, const FitResult& rb, double limit) {
  double worst = 0;
  auto near = [&](double a, double b, double sigma) {
    const double d = std::abs(a - b) / sigma;
    worst = std::max(worst, d);
    EXPECT_LT(d, limit) << a << " vs " << b << " (sigma " << sigma << ")";
  };
  for (int k = 0; k < 3; ++k) {
    near(ra.material.kd[k], rb.material.kd[k], ra.sigma.at("kd")[k]);
    near(ra.material.ks[k], rb.material.ks[k], ra.sigma.at("ks")[k]);
  }
  near(ra.material.n, rb.material.n, ra.sigma.at("n")[0]);
  if (ra.sigma.count("fiber_angle_deg"))
    near(ra.material.fiber_angle_deg, rb.material.fiber_angle_deg,
         ra.sigma.at("fiber_angle_deg")[0]);
  else  // held
    EXPECT_EQ(ra.material.fiber_angle_deg, rb.material.fiber_angle_deg);
  return worst;
}

// The three solvers of the plain line model land on the same estimate and the same
// uncertainties: the fused Levenberg-Marquardt (the default: one pass over the observations per
// step, fit/solvers/line_solve.h), Ceres on 256-pixel blocks with analytic derivatives and Huber by
// reweighting (--solver ceres), and Ceres with one autodiff block per pixel and its own Huber loss
// (the plainest statement of the problem). Same minimum within a tenth of sigma.
// Progress is told to the sink the options carry (core/progress.h), never printed by the library:
// a fiber fit (views loaded, the start grid, the fused solver's passes) and a Ceres one (its
// iterations) with a recording sink write nothing to stderr.
// A warning carries what it is about, and the material file records it beside the text
// (report.warnings_about): a fit that reads the file back (a --global, the tiles' merge) picks
// warnings out by that, whatever their words; a file without the key is read by the words each
// kind began with.
TEST(FitPaths, WarningsArePickedOutByWhatTheyAreAbout) {
  const std::string dir = test::tmp_dir("set");
  simulate_capture(make_preset("brushed-metal", small(2, 24)), dir);
  FitResult r = fit_capture(read_capture(dir), quiet());
  r.report.warnings = {{"--maps: 3 texels stopped", WarningAbout::kMaps},
                       {"texels the data do not know", WarningAbout::kMaps},
                       {"--maps: only looks like a count", WarningAbout::kOther},
                       {"tile 1/2: no usable pixel", WarningAbout::kTile},
                       {"the solver stopped after 5 steps", WarningAbout::kSolverStopped}};
  const std::string text = fit_text(r);
  auto j = nlohmann::json::parse(text);
  EXPECT_EQ(j["report"]["warnings_about"],
            nlohmann::json({"maps", "maps", "other", "tile", "solver_stopped"}));
  const GivenGlobal g = given_global(text, "g.json", dir);
  ASSERT_EQ(g.warnings.size(), 5u);
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(g.warnings[k].text, r.report.warnings[k].text);
    EXPECT_EQ(g.warnings[k].about, r.report.warnings[k].about) << g.warnings[k].text;
  }
  // Written before the key: by the words.
  j["report"].erase("warnings_about");
  const GivenGlobal old = given_global(j.dump(), "old.json", dir);
  ASSERT_EQ(old.warnings.size(), 5u);
  EXPECT_EQ(old.warnings[0].about, WarningAbout::kMaps);
  EXPECT_EQ(old.warnings[1].about, WarningAbout::kOther);
  EXPECT_EQ(old.warnings[2].about, WarningAbout::kMaps);
  EXPECT_EQ(old.warnings[3].about, WarningAbout::kTile);
  EXPECT_EQ(old.warnings[4].about, WarningAbout::kSolverStopped);
  // A fit given it as --global keeps the warnings about its global values, not its counts over
  // the maps or its tile's rows (it says its own).
  FitOptions o = quiet();
  o.global = g;
  o.maps_w = o.maps_h = 4;
  const FitResult m = fit_capture(read_capture(dir), o);
  std::vector<std::string> carried;
  for (const auto& w : m.report.warnings)
    for (const auto& given : g.warnings)
      if (w.text == given.text) carried.push_back(w.text);
  EXPECT_EQ(carried, (std::vector<std::string>{"--maps: only looks like a count",
                                               "the solver stopped after 5 steps"}));
}

TEST(FitPaths, ProgressGoesToTheSinkNotTheTerminal) {
  struct Recorder : ProgressSink {
    mutable std::vector<std::string> labels, statuses;
    mutable std::mutex mu;
    void advance(const std::string& label, size_t, size_t) const override {
      std::lock_guard<std::mutex> lock(mu);
      if (labels.empty() || labels.back() != label) labels.push_back(label);
    }
    void finish(const std::string&) const override {}
    void status(const std::string& text) const override {
      std::lock_guard<std::mutex> lock(mu);
      statuses.push_back(text);
    }
    void note(const std::string& text) const override { status(text); }
  };
  const std::string dir = test::tmp_dir("progress_sink");
  PresetOptions p = small(6, 48);
  simulate_capture(make_preset("brushed-metal", p), dir);
  const CaptureSet set = read_capture(dir);
  for (const bool ceres : {false, true}) {
    Recorder rec;
    FitOptions o = quiet();
    o.progress = &rec;
    o.model = FitModel::kFiber;
    o.ceres_solver = ceres;
    o.max_iterations = 5;
    testing::internal::CaptureStderr();
    fit_capture(set, o);
    const std::string printed = testing::internal::GetCapturedStderr();
    EXPECT_EQ(printed, "") << (ceres ? "Ceres" : "fused");
    auto has = [](const std::vector<std::string>& v, const std::string& start) {
      return std::any_of(v.begin(), v.end(),
                         [&](const std::string& x) { return x.rfind(start, 0) == 0; });
    };
    EXPECT_TRUE(has(rec.labels, "fit: loading views")) << rec.labels.size();
    EXPECT_TRUE(has(rec.labels, "fit: start grid"));
    EXPECT_TRUE(has(rec.statuses, ceres ? "fit: iteration" : "fit: fiber model, pass"));
    EXPECT_TRUE(has(rec.statuses, ""));  // the status line taken away at the end
  }
}

TEST(FitPaths, FusedSolverAndCeresReachTheSameMinimum) {
  const std::string dir = test::tmp_dir("set");
  PresetOptions p = small(8, 64);
  p.noise = 0.01;
  const SimOptions so = make_preset("brushed-metal", p);
  simulate_capture(so, dir);
  const CaptureSet set = read_capture(dir);
  FitOptions fused = quiet(), chunked = quiet(), per_pixel = quiet();
  chunked.ceres_solver = true;
  per_pixel.chunked = false;
  const FitResult ra = fit_capture(set, fused);
  EXPECT_EQ(ra.report.solver, "fused LM");
  for (const FitOptions* o : {&chunked, &per_pixel}) {
    const FitResult rb = fit_capture(set, *o);
    EXPECT_EQ(rb.report.solver, "ceres");
    const double worst = worst_in_sigma(ra, rb, 0.1);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(ra.sigma.at("kd")[k], rb.sigma.at("kd")[k], 0.05 * rb.sigma.at("kd")[k]);
    std::printf("fused LM vs Ceres (%s): largest difference %.4f sigma; solve %.4f s vs %.4f s\n",
                o->chunked ? "256-pixel blocks" : "per pixel", worst, ra.report.seconds_solve,
                rb.report.seconds_solve);
  }
  // The 4-lane pass (fit/solvers/line_pixel_lanes.h, where the CPU has AVX2) and the scalar pass:
  // the same function in another order of operations, so the same minimum to rounding.
  std::printf("4-lane pass on this CPU: %s\n", fitting::line_lanes_on(true) ? "yes" : "no");
  EXPECT_EQ(ra.report.pass.rfind("4 pixels at a time", 0) == 0, fitting::line_lanes_on(true))
      << ra.report.pass;
  FitOptions scalar = fused;
  scalar.line_lanes.simd = false;
  const FitResult rs = fit_capture(set, scalar);
  EXPECT_EQ(rs.report.pass, "one pixel at a time");
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(ra.material.kd[k], rs.material.kd[k], 1e-6 * ra.sigma.at("kd")[k]);
    EXPECT_NEAR(ra.material.ks[k], rs.material.ks[k], 1e-6 * ra.sigma.at("ks")[k]);
    EXPECT_NEAR(ra.sigma.at("ks")[k], rs.sigma.at("ks")[k], 1e-9 * rs.sigma.at("ks")[k]);
  }
  EXPECT_NEAR(ra.material.n, rs.material.n, 1e-6 * ra.sigma.at("n")[0]);
  EXPECT_NEAR(ra.material.fiber_angle_deg, rs.material.fiber_angle_deg,
              1e-6 * ra.sigma.at("fiber_angle_deg")[0]);
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// Where one material does not describe the sample (a swirled plate fitted globally: residual RMS
// 11x the noise), many pixels lie outside Huber's core. The fused solver's steps use the cost's
// own curvature there (fit/solvers/fused_lm.h, HuberCurvature), and Ceres' reweighted rounds go on
// until the weights settle to 1e-4: both converge and land on the same minimum within a tenth of
// sigma. Before, Ceres stopped after 6 rounds 0.13 sigma off in n and 0.2 in psi, and said
// CONVERGENCE.
TEST(FitPaths, FusedAndCeresAgreeWhereManyPixelsLieOutsideHubersCore) {
  const std::string dir = test::tmp_dir("set");
  PresetOptions p = small(16, 64);
  p.noise = 0.01;
  simulate_capture(make_preset("swirl-plate", p), dir);
  const CaptureSet set = read_capture(dir);
  FitOptions fused = quiet(), ceres = quiet();
  fused.psi_symmetry = ceres.psi_symmetry = PsiSymmetry::kNever;
  ceres.ceres_solver = true;
  const FitResult ra = fit_capture(set, fused), rb = fit_capture(set, ceres);
  EXPECT_EQ(ra.report.solver, "fused LM");
  EXPECT_EQ(rb.report.solver, "ceres");
  EXPECT_GT(ra.report.rms, 5 * ra.report.pixel_noise) << "the set should be one the model misfits";
  for (const FitResult* r : {&ra, &rb}) {
    EXPECT_EQ(r->report.termination, "CONVERGENCE") << r->report.solver;
    for (const std::string& w : r->report.warnings)
      EXPECT_EQ(w.find("may not be the minimum"), std::string::npos) << w;
  }
  std::printf("swirl: fused LM %d iterations, Ceres %d; largest difference %.4f sigma\n",
              ra.report.iterations, rb.report.iterations, worst_in_sigma(ra, rb, 0.1));
  // psi held (as the highlight's symmetry holds it): the fused solver's box keeps it, Ceres holds
  // its block constant; the same minimum of the other numbers, and psi has no sigma of its own.
  fused.hold_psi_deg = ceres.hold_psi_deg = 27.5;
  const FitResult ha = fit_capture(set, fused), hb = fit_capture(set, ceres);
  EXPECT_EQ(ha.report.solver, "fused LM");
  for (const FitResult* r : {&ha, &hb}) {
    EXPECT_EQ(r->material.fiber_angle_deg, 27.5) << r->report.solver;
    EXPECT_EQ(r->sigma.count("fiber_angle_deg"), 0u) << r->report.solver;
    EXPECT_EQ(r->report.termination, "CONVERGENCE") << r->report.solver;
  }
  EXPECT_GT(std::abs(ra.material.n / ha.material.n - 1), 0.01)
      << "held away from its minimum, n should move";
  std::printf("swirl, psi held: largest difference %.4f sigma\n", worst_in_sigma(ha, hb, 0.1));
}

// A large set's robust stage runs on every k-th pixel first, then on every pixel from there
// (fit.h kStagedPixels; lowered here so that these small sets take that path): the minimum is
// that of every pixel, as the unstaged solve's, within a twentieth of sigma (the swirled plate's
// 0.0097 here: the two solvers' stopping rule leaves that much where the model misfits; the
// subsample's own minimum lies sigma's apart), and Ceres' within a tenth. For a model that fits
// (brushed metal, line), one that does not (the swirled plate fitted globally), and the fiber model
// (fiber-flat).
TEST(FitPaths, TheStagedRobustStageReachesTheSameMinimum) {
  struct Case {
    const char* preset;
    FitModel model;
  };
  for (const Case c : {Case{"brushed-metal", FitModel::kLine}, Case{"swirl-plate", FitModel::kLine},
                       Case{"fiber-flat", FitModel::kFiber}}) {
    const std::string dir = test::tmp_dir(std::string("staged_") + c.preset);
    PresetOptions p = small(8, 64);
    p.noise = 0.01;
    simulate_capture(make_preset(c.preset, p), dir);
    const CaptureSet set = read_capture(dir);
    FitOptions whole = quiet(), staged = quiet(), ceres = quiet();
    whole.model = staged.model = ceres.model = c.model;
    whole.staged_pixels = 0;     // never
    staged.staged_pixels = 500;  // every 16th pixel first (the sets hold ~10 000)
    ceres.staged_pixels = 0;
    ceres.ceres_solver = true;
    const FitResult ra = fit_capture(set, whole), rs = fit_capture(set, staged);
    EXPECT_EQ(ra.report.staged_stride, 0) << c.preset;
    EXPECT_EQ(rs.report.staged_stride, kStagedStride) << c.preset;
    EXPECT_GT(rs.report.staged_iterations, 0) << c.preset;
    EXPECT_EQ(rs.report.termination, "CONVERGENCE") << c.preset;
    const double apart = worst_in_sigma(rs, ra, 0.05);
    double from_ceres = -1;
    if (c.model == FitModel::kLine) {  // the fiber model's Ceres path: tests/test_fiber_model.cpp
      const FitResult rc = fit_capture(set, ceres);
      EXPECT_EQ(rc.report.solver, "ceres");
      from_ceres = worst_in_sigma(rs, rc, 0.1);
    }
    std::printf(
        "%s: staged %d on every %dth pixel + %d, unstaged %d iterations; apart %.5f sigma, "
        "from Ceres %.4f sigma\n",
        c.preset, rs.report.staged_iterations, rs.report.staged_stride, rs.report.iterations,
        ra.report.iterations, apart, from_ceres);
  }
}

// --topology-map N: a per-texel map of s over uv, recovered texel by texel on a flat sample whose
// topology varies over its surface; the map is written beside the material.
TEST(FitFiber, PerTexelTopologyMap) {
  const std::string dir = test::tmp_dir("set");
  const SimOptions so = make_preset("fiber-flat-map", small(6, 64));
  simulate_capture(so, dir);
  FitOptions fo = quiet();
  fo.model = FitModel::kFiber;
  fo.topology_texels = 8;
  FitResult r;
  const TruthErrors e = fit_and_compare(dir, read_material(dir + "/truth.json"), fo, &r);
  EXPECT_EQ(r.s_texels.size(), 64u);
  EXPECT_LT(e.topo_abs, 0.01);
  EXPECT_LT(e.kd_rel, 0.01);
  EXPECT_LT(e.n_rel, 0.02);
  write_fit(dir + "/out/m.json", r);
  EXPECT_TRUE(std::filesystem::exists(test::map_of(dir + "/out/m", "topology_s")));
  const Material back = read_material(dir + "/out/m.json");
  EXPECT_NE(back.topology_as<SMapRef>(), nullptr);
  // Asked of a set without uv or with a topology map: a clear error.
  FitOptions line = fo;
  line.model = FitModel::kLine;
  EXPECT_THROW(fit_capture(read_capture(dir), line), Error);
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// The normal-equation covariance (one pass, O(P^2) memory) against Ceres' dense SVD of the whole
// Jacobian on the same solved problems: every sigma and every correlation agree, with the optional
// terms (a subset manifold where a coordinate is held), per-pixel and chunked problems, and the
// fiber model.
TEST(FitPaths, NormalEquationCovarianceMatchesCeres) {
  struct Case {
    const char* preset;
    FitModel model;
    bool iso, second, chunked;
  };
  for (const Case& c : {Case{"brushed-metal", FitModel::kLine, false, false, true},
                        Case{"brushed-metal", FitModel::kLine, false, false, false},
                        Case{"woven-cloth", FitModel::kLine, true, true, false},
                        Case{"fiber-flat", FitModel::kFiber, false, false, false}}) {
    const std::string dir = test::tmp_dir(std::string("set_") + c.preset);
    PresetOptions p = small(6, 32);
    p.noise = 0.01;
    simulate_capture(make_preset(c.preset, p), dir);
    const CaptureSet set = read_capture(dir);
    FitOptions a = quiet();
    a.model = c.model;
    a.fit_isotropic = c.iso;
    a.fit_second = c.second;
    a.chunked = c.chunked;
    a.ceres_solver = true;  // both solved by Ceres: the same minimum, two covariances
    FitOptions b = a;
    b.ceres_covariance = true;
    const FitResult ra = fit_capture(set, a), rb = fit_capture(set, b);
    EXPECT_EQ(ra.report.covariance, "normal equations") << c.preset;
    EXPECT_EQ(rb.report.covariance, "ceres dense SVD") << c.preset;
    ASSERT_EQ(ra.sigma.size(), rb.sigma.size()) << c.preset;
    EXPECT_EQ(ra.undetermined.size(), rb.undetermined.size()) << c.preset;
    double worst = 0;
    for (const auto& [key, sa] : ra.sigma) {
      ASSERT_TRUE(rb.sigma.count(key)) << key;
      const auto& sb = rb.sigma.at(key);
      for (size_t i = 0; i < sa.size(); ++i)
        worst = std::max(worst, std::abs(sa[i] - sb[i]) / std::max(sb[i], 1e-300));
    }
    double worst_corr = 0;
    ASSERT_EQ(ra.correlation.size(), rb.correlation.size()) << c.preset;
    for (size_t i = 0; i < ra.correlation.size(); ++i)
      for (size_t j = 0; j < ra.correlation.size(); ++j)
        worst_corr = std::max(worst_corr, std::abs(ra.correlation[i][j] - rb.correlation[i][j]));
    std::printf(
        "%s (%s%s%s): normal equations vs Ceres covariance: sigma rel. diff %.2g, "
        "correlation diff %.2g; time %.4f s vs %.4f s\n",
        c.preset, c.model == FitModel::kFiber ? "fiber" : "line", c.iso ? " +iso" : "",
        c.chunked ? " chunked" : " per pixel", worst, worst_corr, ra.report.seconds_covariance,
        rb.report.seconds_covariance);
    EXPECT_LT(worst, 1e-6) << c.preset;
    EXPECT_LT(worst_corr, 1e-6) << c.preset;
  }
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// The line model with its isotropic part, hand-written derivatives (--fit-isotropic and the
// comparison with the isotropic part alone) against Ceres' automatic derivatives of
// models/line_model.h, at random pixels of two lights each (above the horizon, as the records
// hold them) and random parameters.
struct LineIsotropicByJets {
  const fitting::Observation* obs;
  const fitting::ObsLight* lights;
  template <class T>
  bool operator()(const T* kd, const T* ks, const T* logn, const T* psi, const T* iso, T* r) const {
    LineParamsT<T> p = fitting::fitted_params(kd, ks, logn, psi);
    p.isotropic = true;
    for (int k = 0; k < 3; ++k) p.kd_iso[k] = iso[k], p.ks_iso[k] = iso[3 + k];
    p.n_iso = exp(iso[6]);
    fitting::pixel_residual(
        obs, lights,
        [&](const LocalDir& L, const LocalDir& V, T* f) { line_reflectance(p, L, V, f); }, r);
    return true;
  }
};

TEST(FitPaths, TheIsotropicPartsHandWrittenDerivativesAreAutomaticOnes) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1), pos(0.05, 0.9);
  auto dir = [&]() {
    double x = u(rng), y = u(rng), z = pos(rng);
    const double l = std::sqrt(x * x + y * y + z * z);
    return LocalDir{x / l, y / l, z / l};
  };
  fitting::ObsSet os;
  for (int i = 0; i < 200; ++i) {
    fitting::Observation o;
    o.V = dir();
    o.first_light = static_cast<uint32_t>(os.lights.size());
    o.num_lights = 2;
    for (int k = 0; k < 2; ++k) {
      fitting::ObsLight l;
      l.L = dir();  // the records hold lights above the horizon only
      for (float& e : l.E) e = static_cast<float>(pos(rng));
      os.lights.push_back(l);
    }
    for (float& y : o.y) y = static_cast<float>(pos(rng));
    os.obs.push_back(o);
  }
  double worst = 0, scale = 0;
  for (size_t i = 0; i < os.obs.size(); ++i) {
    const double kd[3] = {pos(rng), pos(rng), pos(rng)}, ks[3] = {pos(rng), pos(rng), pos(rng)};
    const double logn = std::log(2 + 60 * pos(rng)), psi = 3 * u(rng);
    const double iso[7] = {
        pos(rng), pos(rng), pos(rng), pos(rng), pos(rng), pos(rng), std::log(1 + 40 * pos(rng))};
    double ra[3], rb[3], ja[5][21], jb[5][21];
    double* Ja[5] = {ja[0], ja[1], ja[2], ja[3], ja[4]};
    double* Jb[5] = {jb[0], jb[1], jb[2], jb[3], jb[4]};
    fitting::line_isotropic_pixel(os, i, kd, ks, logn, psi, iso, ra, Ja);
    ceres::AutoDiffCostFunction<LineIsotropicByJets, 3, 3, 3, 1, 1, 7> jets(
        new LineIsotropicByJets{&os.obs[i], os.lights.data()});
    const double* params[5] = {kd, ks, &logn, &psi, iso};
    ASSERT_TRUE(jets.Evaluate(params, rb, Jb));
    const int sizes[5] = {9, 9, 3, 3, 21};
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(ra[c] - rb[c]));
    for (int b = 0; b < 5; ++b)
      for (int k = 0; k < sizes[b]; ++k) {
        worst = std::max(worst, std::abs(ja[b][k] - jb[b][k]));
        scale = std::max(scale, std::abs(jb[b][k]));
      }
  }
  std::printf(
      "line + isotropic pixel: hand-written against automatic derivatives within %.2e "
      "(largest entry %.3g)\n",
      worst, scale);
  EXPECT_LT(worst, 1e-9 * std::max(1.0, scale));
}

}  // namespace
}  // namespace aniso
