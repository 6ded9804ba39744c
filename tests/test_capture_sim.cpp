// capture_sim: real Embree scenes, shadow rays only where a shape can shadow itself, seeded
// sensor noise, geometry traced once for a fixed camera.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "capture_sim/sim.h"
#include "core/gauss.h"
#include "datasets_synth/presets.h"
#include "fit/fit.h"
#include "geometry/raycast.h"
#include "io/formats/capture.h"
#include "io/images/image_io.h"
#include "render/preview/verify.h"
#include "test_util.h"

namespace aniso {
namespace {

PresetOptions small(int views = 4) {
  PresetOptions p;
  p.views = views;
  p.width = p.height = 48;
  p.progress = nullptr;
  return p;
}

TEST(CaptureSim, ShadowRaysOnlyForShapesThatCanShadowThemselves) {
  const std::string dir = test::tmp_dir("sets");
  for (const char* preset : {"brushed-metal", "satin-ball", "cd"}) {
    const SimStats st = simulate_capture(make_preset(preset, small()), dir + "/" + preset);
    EXPECT_EQ(st.shadow_rays, 0u) << preset;
    EXPECT_GT(st.light_evals, 0u) << preset;
  }
  SimOptions torus = make_preset("brushed-metal", small());
  torus.shape = "torus";
  torus.camera = frame_camera(48, 48, 1.4, 4.0);
  const SimStats st = simulate_capture(torus, dir + "/torus");
  EXPECT_GT(st.shadow_rays, 0u);
  // The shadows are real: rendering the torus set without shadow rays disagrees somewhere.
  const VerifyResult v = verify_capture(read_capture(dir + "/torus"), torus.truth);
  EXPECT_GT(v.overall.max_abs, 1e-3);
  const VerifyResult vs =
      verify_capture(read_capture(dir + "/satin-ball"), make_preset("satin-ball", small()).truth);
  EXPECT_LT(vs.overall.max_abs, 1e-5);
}

TEST(CaptureSim, FixedCameraTracesGeometryOnce) {
  const std::string dir = test::tmp_dir("sets");
  const SimStats fixed = simulate_capture(make_preset("brushed-metal", small(6)), dir + "/fixed");
  EXPECT_EQ(fixed.primary_rays, 48u * 48u);
  PresetOptions o = small(6);
  o.rig = "orbit";
  const SimStats orbit = simulate_capture(make_preset("brushed-metal", o), dir + "/orbit");
  EXPECT_EQ(orbit.primary_rays, 6u * 48u * 48u);
  const CaptureSet s = read_capture(dir + "/orbit");
  EXPECT_NE(s.views[0].geometry.position, s.views[1].geometry.position);
}

// A sensor that records the radiance as it is (float, no noise, no clipping: the default) has
// each view written as soon as it is shaded, none kept for the white level; its images are
// those of the path that keeps them all (a saturation too high to clip anything) bit for bit,
// with a moving camera (geometry per view, written alongside) and a fixed one.
TEST(CaptureSim, StreamedViewsEqualTheKeptOnes) {
  const std::string dir = test::tmp_dir("sets");
  for (const char* rig : {"orbit", "fixed-camera"}) {
    PresetOptions o = small(5);
    o.rig = rig;
    SimOptions streamed = make_preset("satin-ball", o), kept = streamed;
    kept.sensor.saturation = 1e30;
    const SimStats a = simulate_capture(streamed, dir + "/streamed_" + rig);
    const SimStats b = simulate_capture(kept, dir + "/kept_" + rig);
    EXPECT_EQ(a.white_level, b.white_level) << rig;
    for (int v = 0; v < 5; ++v) {
      const std::string f = "/images/00" + std::to_string(v) + ".exr";
      EXPECT_EQ(read_image(dir + "/streamed_" + rig + f).image.px,
                read_image(dir + "/kept_" + rig + f).image.px)
          << rig << f;
    }
    const CaptureSet s = read_capture(dir + "/streamed_" + rig);
    ASSERT_EQ(s.views.size(), 5u);
    EXPECT_EQ(s.views[4].image, "images/004.exr");
  }
}

// synth --kept-radiance-gb 0: a noisy set shaded twice, as the synth line says, with the same
// images as the default budget (which keeps them).
TEST(CaptureSim, KeptRadianceBudgetFromTheCommandLine) {
  const std::string dir = test::tmp_dir("sets");
  const std::string args = " --size 48x48 --views 3 --noise 0.01 --bits 16";
  const auto twice =
      test::run_cli("synth satin-ball " + dir + "/twice" + args + " --kept-radiance-gb 0");
  const auto kept = test::run_cli("synth satin-ball " + dir + "/kept" + args);
  ASSERT_EQ(twice.status, 0) << twice.output;
  ASSERT_EQ(kept.status, 0) << kept.output;
  EXPECT_NE(twice.output.find("every view shaded twice"), std::string::npos) << twice.output;
  EXPECT_EQ(kept.output.find("every view shaded twice"), std::string::npos) << kept.output;
  for (const char* f : {"/images/000.png", "/images/002.png"})
    EXPECT_EQ(read_image(dir + "/twice" + f).image.px, read_image(dir + "/kept" + f).image.px) << f;
}

// The benchmark's switch that writes nothing traces and shades the same views (the same rays, the
// same white level) and leaves no folder behind.
TEST(CaptureSim, WritingNoFilesTracesTheSameAndLeavesNothing) {
  const std::string dir = test::tmp_dir("sets");
  PresetOptions o = small(3);
  o.rig = "orbit";
  SimOptions written = make_preset("satin-ball", o), dry = written;
  dry.write_files = false;
  const SimStats a = simulate_capture(written, dir + "/written");
  const SimStats b = simulate_capture(dry, dir + "/dry");
  EXPECT_EQ(a.primary_rays, b.primary_rays);
  EXPECT_EQ(a.shaded_pixels, b.shaded_pixels);
  EXPECT_EQ(a.white_level, b.white_level);
  EXPECT_GT(b.primary_rays, 0u);
  EXPECT_FALSE(std::filesystem::exists(dir + "/dry"));
}

// Beyond the memory budget for the kept radiance a noisy 16-bit set is traced and shaded twice,
// the white level first: the same files as keeping every view's radiance.
TEST(CaptureSim, ShadingTwiceBoundsMemoryAndGivesTheSameSet) {
  const std::string dir = test::tmp_dir("sets");
  PresetOptions o = small(4);
  o.rig = "orbit";
  o.noise = 0.01;
  o.bits = 16;
  SimOptions kept = make_preset("satin-ball", o), twice = kept;
  twice.kept_radiance_bytes = 0;
  const SimStats a = simulate_capture(kept, dir + "/kept");
  const SimStats b = simulate_capture(twice, dir + "/twice");
  EXPECT_EQ(a.passes, 1);
  EXPECT_EQ(b.passes, 2);
  EXPECT_EQ(a.white_level, b.white_level);
  for (int v = 0; v < 4; ++v) {
    const std::string f = "/images/00" + std::to_string(v) + ".png";
    EXPECT_EQ(read_image(dir + "/kept" + f).image.px, read_image(dir + "/twice" + f).image.px) << f;
  }
  EXPECT_EQ(read_capture(dir + "/kept").views[3].exposure,
            read_capture(dir + "/twice").views[3].exposure);
}

TEST(CaptureSim, NoiseIsSeededAndRecorded) {
  const std::string dir = test::tmp_dir("sets");
  PresetOptions o = small(2);
  o.noise = 0.02;
  o.shot_photons = 1000;
  o.seed = 42;
  simulate_capture(make_preset("brushed-metal", o), dir + "/a");
  simulate_capture(make_preset("brushed-metal", o), dir + "/b");
  o.seed = 43;
  simulate_capture(make_preset("brushed-metal", o), dir + "/c");
  const Image a = read_image(dir + "/a/images/001.exr").image,
              b = read_image(dir + "/b/images/001.exr").image,
              c = read_image(dir + "/c/images/001.exr").image;
  EXPECT_EQ(a.px, b.px);
  EXPECT_NE(a.px, c.px);
  const CaptureSet s = read_capture(dir + "/a");
  EXPECT_NE(s.provenance.find("\"seed\":42"), std::string::npos) << s.provenance;
}

// The sensor's noise: the ziggurat's samples against the normal distribution itself, in the core
// (Kolmogorov-Smirnov distance), the moments and the tail beyond r = 3.44 (its own sampler).
TEST(CaptureSim, ZigguratNoiseIsStandardNormal) {
  std::mt19937_64 rng(7);
  const ZigguratNormal gauss;
  constexpr int kN = 1 << 21;
  std::vector<double> v(kN);
  double m1 = 0, m2 = 0, m4 = 0;
  size_t beyond_r = 0;
  for (double& x : v) {
    x = gauss(rng);
    ASSERT_TRUE(std::isfinite(x));
    m1 += x, m2 += x * x, m4 += x * x * x * x;
    beyond_r += std::abs(x) > 3.442619855899;
  }
  m1 /= kN, m2 /= kN, m4 /= kN;
  EXPECT_NEAR(m1, 0.0, 4e-3);
  EXPECT_NEAR(m2, 1.0, 4e-3);
  EXPECT_NEAR(m4, 3.0, 0.04);
  const double tail = std::erfc(3.442619855899 / std::sqrt(2.0));  // both sides
  EXPECT_NEAR(static_cast<double>(beyond_r) / kN, tail, 5 * std::sqrt(tail / kN));
  std::sort(v.begin(), v.end());
  double ks = 0;
  for (int i = 0; i < kN; ++i) {
    const double cdf = 0.5 * std::erfc(-v[i] / std::sqrt(2.0));
    ks = std::max({ks, std::abs(cdf - double(i) / kN), std::abs(cdf - double(i + 1) / kN)});
  }
  EXPECT_LT(ks, 1.63 / std::sqrt(double(kN)));  // the 1 % critical value
}

TEST(CaptureSim, IntegerSensorQuantisesAndClips) {
  const std::string dir = test::tmp_dir("sets");
  PresetOptions o = small(2);
  o.bits = 8;
  o.encoding = "srgb";
  simulate_capture(make_preset("brushed-metal", o), dir + "/p");
  const LoadedImage li = read_image(dir + "/p/images/000.png");
  EXPECT_EQ(li.bits, 8);
  for (float v : li.image.px) {
    EXPECT_GE(v, 0.f);
    EXPECT_LE(v, 1.f);
    EXPECT_NEAR(v * 255, std::round(v * 255), 1e-3);
  }
}

TEST(CaptureSim, ObjMeshGeometryByRayCasting) {
  const std::string dir = test::tmp_dir("obj");
  std::ofstream(dir + "/sq.obj") << "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
  Intrinsics k{16, 16, 20, 20, 7.5, 7.5};
  const Mat4 pose = look_at({0, 0, 3}, {0, 0, 0}, {0, 1, 0});
  Image P, N, U;
  std::vector<uint8_t> mask(16 * 16, 1);
  trace_mesh_gbuffer(dir + "/sq.obj", "", k, pose, &P, &N, &U, &mask);
  EXPECT_TRUE(mask[8 * 16 + 8]);
  EXPECT_NEAR(N.at(8, 8, 2), 1.0, 1e-6);
  EXPECT_NEAR(U.at(8, 8, 0), 1.0, 1e-6);  // dP/du = +x
  EXPECT_NEAR(P.at(8, 8, 2), 0.0, 1e-5);
  // A fiber field replaces dP/du: circular about the z axis through the mesh centre.
  trace_mesh_gbuffer(dir + "/sq.obj", "circular", k, pose, &P, &N, &U, &mask);
  const Vec3 p{P.at(12, 8, 0), P.at(12, 8, 1), 0},
      u{U.at(12, 8, 0), U.at(12, 8, 1), U.at(12, 8, 2)};
  EXPECT_NEAR(dot(normalize(p), u), 0.0, 1e-5);
}

}  // namespace
}  // namespace aniso

#include "capture_sim/microgeometry.h"
#include "models/fiber_model.h"

namespace aniso {
namespace {

// The virtual gonioreflectometer (real Embree cylinders, shadow rays) measures what the fiber
// model predicts, within its statistical error, across topology and directions.
TEST(MicroGeometry, MeasuresWhatTheFiberModelPredicts) {
  const double d = M_PI / 180;
  auto dir = [&](double t, double p) {
    return LocalDir{std::sin(t * d) * std::cos(p * d), std::sin(t * d) * std::sin(p * d),
                    std::cos(t * d)};
  };
  for (double s : {0.0, 0.4, 0.8}) {
    const MicroPatch patch(s);
    for (const auto& [L, V] :
         std::vector<std::pair<LocalDir, LocalDir>>{{dir(30, 90), dir(30, 270)},
                                                    {dir(60, 80), dir(20, 200)},
                                                    {dir(75, 90), dir(60, 90)},
                                                    {dir(50, 130), dir(70, 10)}}) {
      const MicroMeasurement m = patch.measure(L, V, 20.0, 20000, 3);
      double D, S;
      fiber_DS(L.w, L.n, V.w, V.n, L.u, V.u, 20.0, s, FiberAccuracy{}, &D, &S);
      EXPECT_NEAR(m.D, D, 4 * m.D_se + 1e-4) << "s=" << s;
      EXPECT_NEAR(m.S, S, 4 * m.S_se + 1e-4) << "s=" << s;
      EXPECT_GT(m.rays, 20000u);  // shadow rays were cast too
    }
  }
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// An explicit rig: camera positions and lights of every kind from a JSON list; the set carries
// them exactly and the fit recovers the material under them.
TEST(CaptureSim, ExplicitRigWithSpotAndDirectionalLights) {
  const std::string dir = test::tmp_dir("rig");
  std::ofstream(dir + "/rig.json") << R"({"views": [
    {"camera": [0, -2.5, 3], "lights": [{"type": "spot", "position": [1, 1, 3], "intensity": 12,
      "direction": [-0.3, -0.3, -1], "cutoff_deg": 60, "exponent": 2, "attenuation": [0, 0, 1]}]},
    {"camera": [0, -2.5, 3], "lights": [{"type": "directional", "direction": [-1, 0.5, 1.5], "irradiance": 1}]},
    {"camera": [1, -2, 3], "lights": [{"type": "point", "position": [-2, 1, 2], "intensity": [9, 8, 7],
      "attenuation": [1, 0, 1]}]},
    {"camera": [-1, -2, 3], "lights": [{"type": "point", "position": [2, 2, 1.5], "intensity": 9}]}]})";
  PresetOptions p;
  p.views = 1;
  p.width = p.height = 64;
  p.progress = nullptr;
  p.rig = dir + "/rig.json";
  const SimOptions so = make_preset("brushed-metal", p);
  ASSERT_EQ(so.rig.size(), 4u);
  simulate_capture(so, dir + "/set");
  const CaptureSet s = read_capture(dir + "/set");
  EXPECT_EQ(s.views[0].lights[0].type, Light::Type::kSpot);
  EXPECT_DOUBLE_EQ(s.views[0].lights[0].cutoff_deg, 60);
  EXPECT_EQ(s.views[1].lights[0].type, Light::Type::kDirectional);
  EXPECT_DOUBLE_EQ(s.views[2].lights[0].attenuation[0], 1);
  EXPECT_NE(s.views[0].geometry.position, s.views[2].geometry.position);  // the camera moved
  FitOptions fo;
  fo.progress = nullptr;
  const FitResult r = fit_capture(s, fo);
  EXPECT_NEAR(r.material.n, so.truth.n, 0.01 * so.truth.n);
  EXPECT_NEAR(r.material.kd[0], so.truth.kd[0], 0.005 * so.truth.kd[0]);
}

}  // namespace
}  // namespace aniso

#include "geometry/embree_device.h"

namespace aniso {
namespace {

// Embree errors reach the user with their code and message, on every device.
TEST(Embree, ErrorsArePrintedWithCodeAndMessage) {
  RTCDevice dev = new_embree_device("test");
  testing::internal::CaptureStderr();
  RTCGeometry g = rtcNewGeometry(dev, static_cast<RTCGeometryType>(12345));  // no such type
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(g, nullptr);
  EXPECT_NE(err.find("Embree error in test: RTC_ERROR_"), std::string::npos) << err;
  EXPECT_GT(err.size(), 40u) << err;  // Embree's own message follows the code
  rtcReleaseDevice(dev);
}

}  // namespace
}  // namespace aniso
