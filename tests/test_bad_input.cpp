// Bad input through the real CLI: a message naming the file and key, a non-zero exit, and no
// output file left behind.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>

#include "datasets_synth/presets.h"
#include "io/files/files.h"
#include "io/formats/capture.h"
#include "io/images/image_io.h"
#include "test_util.h"

namespace aniso {
namespace {

namespace fs = std::filesystem;

// A small valid capture to break in different ways.
std::string good_capture(const std::string& dir) {
  PresetOptions p;
  p.views = 2;
  p.width = p.height = 24;
  p.progress = nullptr;
  simulate_capture(make_preset("brushed-metal", p), dir);
  return dir;
}

void expect_failure(const std::string& args, const std::vector<std::string>& must_mention,
                    const std::string& out) {
  const test::RunResult r = test::run_cli(args);
  EXPECT_NE(r.status, 0) << r.output;
  for (const auto& s : must_mention)
    EXPECT_NE(r.output.find(s), std::string::npos) << "'" << s << "' not in: " << r.output;
  EXPECT_FALSE(fs::exists(out)) << out << " was written";
  // No temporary left beside it either.
  for (const auto& e : fs::directory_iterator(fs::path(out).parent_path()))
    EXPECT_EQ(e.path().filename().string().find("aniso-tmp"), std::string::npos) << e.path();
}

TEST(BadInput, MissingFile) {
  const std::string dir = test::tmp_dir("x");
  expect_failure("fit " + dir + "/nope --out " + dir + "/m.json", {"x/nope", "not found"},
                 dir + "/m.json");
  expect_failure("bake " + dir + "/nope.json --out " + dir + "/bake", {"nope.json"}, dir + "/bake");
}

TEST(BadInput, MalformedJson) {
  const std::string dir = test::tmp_dir("x");
  std::ofstream(dir + "/capture.json") << "{\"format\": \"aniso-capture\", \"version\": 1,";
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"capture.json", "malformed JSON"},
                 dir + "/m.json");
}

TEST(BadInput, UnknownVersionAndFormat) {
  const std::string dir = good_capture(test::tmp_dir("set"));
  test::edit_json(dir + "/capture.json", [](auto& j) { j["version"] = 7; });
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"capture.json", "version", "7"},
                 dir + "/m.json");
  test::edit_json(dir + "/capture.json", [](auto& j) {
    j["version"] = 1;
    j["format"] = "something-else";
  });
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"capture.json", "format"},
                 dir + "/m.json");
}

TEST(BadInput, ImageSizeMismatch) {
  const std::string dir = good_capture(test::tmp_dir("set"));
  write_exr(dir + "/images/001.exr", Image(10, 12, 3, 0.5f));
  expect_failure("fit " + dir + " --out " + dir + "/m.json",
                 {"views[1].image", "001.exr", "10x12", "24x24"}, dir + "/m.json");
}

// An EXR with non-finite pixels, as another tool may write (our writer refuses to).
void write_raw_exr(const std::string& path, const Image& img) {
  Imf::Header header(img.width, img.height);
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
  Imf::OutputFile file(path.c_str(), header);
  Imf::FrameBuffer fb;
  char* base = const_cast<char*>(reinterpret_cast<const char*>(img.px.data()));
  const size_t xs = 3 * sizeof(float), ys = xs * img.width;
  fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
  fb.insert("G", Imf::Slice(Imf::FLOAT, base + 4, xs, ys));
  fb.insert("B", Imf::Slice(Imf::FLOAT, base + 8, xs, ys));
  file.setFrameBuffer(fb);
  file.writePixels(img.height);
}

// A float image's pixels sorted against the definitions (off the mask: kOff and 0; a value or
// the geometry not finite: kNonfinite; a value at or above the saturation: kSaturated; else
// kUsable, its values as written), over rows of 37 pixels (two blocks of the sixteen-pixel
// lanes and a tail) with every case at random places: NaN, +-Inf, values at, just under and
// just over the saturation, a geometry not finite.
TEST(BadInput, FloatPixelsAreSortedAsTheyAreDefined) {
  const std::string dir = test::tmp_dir("classify");
  std::filesystem::create_directories(dir + "/g");
  const int W = 37, H = 6;
  const float sat = 0.8f;
  Image P(W, H, 3), N(W, H, 3), U(W, H, 3), img(W, H, 3), mask(W, H, 1);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> pick(0, 19);
  const float inf = std::numeric_limits<float>::infinity();
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      P.at(x, y, 0) = float(x), P.at(x, y, 1) = float(y);
      N.at(x, y, 2) = 1;
      U.at(x, y, 0) = 1;
      if (pick(rng) == 0) N.at(x, y, 1) = NAN;  // geometry not finite
      mask.at(x, y, 0) = pick(rng) < 4 ? 0.f : 1.f;
      for (int c = 0; c < 3; ++c) {
        const float special[8] = {
            NAN, inf, -inf, sat, std::nextafter(sat, 0.f), std::nextafter(sat, 1.f), 3.f, -0.5f};
        const int k = pick(rng);
        img.at(x, y, c) = k < 8 ? special[k] : 0.05f * k;
      }
    }
  write_exr(dir + "/g/P.exr", P);
  write_raw_exr(dir + "/g/N.exr", N);
  write_exr(dir + "/g/U.exr", U);
  write_png(dir + "/g/mask.png", mask, 8);
  write_raw_exr(dir + "/img.exr", img);
  std::ofstream(dir + "/capture.json") << R"({"format":"aniso-capture","version":1,
    "camera":{"width":37,"height":6,"fx":10,"fy":10,"cx":18,"cy":3},
    "color":{"saturation":0.8},
    "geometry":{"position":"g/P.exr","normal":"g/N.exr","tangent":"g/U.exr","mask":"g/mask.png"},
    "views":[{"image":"img.exr","world_from_camera":[[1,0,0,0],[0,1,0,0],[0,0,1,-3],[0,0,0,1]],
              "lights":[{"type":"directional","direction":[0,0,1],"irradiance":1}]}]})";
  // Both forms where the CPU has the sixteen-pixel one (CI's AVX2 machines have only the other).
  for (const bool lanes : {true, false}) {
    SCOPED_TRACE(lanes ? "sixteen at a time where the CPU allows" : "one at a time");
    const ViewData d = load_view(read_capture(dir), 0, nullptr, nullptr, nullptr, lanes);
    size_t count[4] = {0, 0, 0, 0};
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t p = static_cast<size_t>(y) * W + x;
        bool finite = std::isfinite(N.at(x, y, 1)), hot = false;
        for (int c = 0; c < 3; ++c) {
          finite = finite && std::isfinite(img.at(x, y, c));
          hot = hot || img.at(x, y, c) >= sat;
        }
        const uint8_t want = mask.at(x, y, 0) == 0 ? ViewData::kOff
                             : !finite             ? ViewData::kNonfinite
                             : hot                 ? ViewData::kSaturated
                                                   : ViewData::kUsable;
        ASSERT_EQ(d.use[p], want) << "pixel " << x << ", " << y;
        ++count[want];
        for (int c = 0; c < 3; ++c) {
          const float got = d.rgb.at(x, y, c), put = want == ViewData::kOff ? 0.f : img.at(x, y, c);
          EXPECT_TRUE(std::memcmp(&got, &put, sizeof got) == 0) << x << ", " << y << " " << c;
        }
      }
    std::printf("off %zu, usable %zu, saturated %zu, not finite %zu\n", count[0], count[1],
                count[2], count[3]);
    EXPECT_EQ(d.used, count[ViewData::kUsable]);
    EXPECT_EQ(d.saturated, count[ViewData::kSaturated]);
    EXPECT_EQ(d.nonfinite, count[ViewData::kNonfinite]);
    EXPECT_EQ(d.mask_pixels, static_cast<size_t>(W * H) - count[ViewData::kOff]);
    for (size_t k : count) EXPECT_GT(k, 10u);
  }
}

TEST(BadInput, NanPixelsAreLeftOutAndAllNanFails) {
  const std::string dir = good_capture(test::tmp_dir("set"));
  Image img = read_image(dir + "/images/000.exr").image;
  for (size_t i = 0; i < img.px.size(); i += 7) img.px[i] = NAN;
  write_raw_exr(dir + "/images/000.exr", img);
  const test::RunResult ok = test::run_cli("fit " + dir + " --out " + dir + "/m.json");
  ASSERT_EQ(ok.status, 0) << ok.output;
  const auto j = nlohmann::json::parse(read_text_file(dir + "/m.json"));
  EXPECT_GT(j["report"]["skipped"]["nonfinite"].get<int>(), 50);
  fs::remove(dir + "/m.json");
  for (const char* v : {"000", "001"})
    write_raw_exr(dir + "/images/" + v + ".exr", Image(24, 24, 3, NAN));
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"no usable observations"},
                 dir + "/m.json");
}

// A non-finite value in a geometry buffer (checked once per geometry, which the views share):
// that pixel is left out of every view and counted as not finite in each, the rest fitted.
TEST(BadInput, NanGeometryPixelsAreLeftOutOfEveryView) {
  const std::string dir = good_capture(test::tmp_dir("geo"));
  const auto set = nlohmann::json::parse(read_text_file(dir + "/capture.json"));
  const std::string normal = dir + "/" + set["geometry"]["normal"].get<std::string>();
  test::RunResult r = test::run_cli("fit " + dir + " --out " + dir + "/a.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto a = nlohmann::json::parse(read_text_file(dir + "/a.json"));
  Image n = read_image(normal).image;
  size_t spoiled = 0;
  for (size_t p = 0; p < n.px.size() / 3; p += 5, ++spoiled) n.px[3 * p + 1] = NAN;
  write_raw_exr(normal, n);
  r = test::run_cli("fit " + dir + " --out " + dir + "/b.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto b = nlohmann::json::parse(read_text_file(dir + "/b.json"));
  const int lost = a["report"]["pixels"].get<int>() - b["report"]["pixels"].get<int>();
  EXPECT_GT(lost, 0);
  EXPECT_EQ(b["report"]["skipped"]["nonfinite"].get<int>(), lost) << "every pixel lost is counted";
  EXPECT_LE(static_cast<size_t>(lost), 2 * spoiled);  // at most the spoiled pixels of two views
}

TEST(BadInput, EmptyMask) {
  const std::string dir = good_capture(test::tmp_dir("set"));
  write_png(dir + "/geometry/all_mask.png", Image(24, 24, 1, 0.f), 8);
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"no usable observations"},
                 dir + "/m.json");
}

TEST(BadInput, NoLights) {
  const std::string dir = good_capture(test::tmp_dir("set"));
  test::edit_json(dir + "/capture.json",
                  [](auto& j) { j["views"][1]["lights"] = nlohmann::json::array(); });
  expect_failure("fit " + dir + " --out " + dir + "/m.json",
                 {"capture.json", "views[1].lights", "at least one light"}, dir + "/m.json");
}

TEST(BadInput, UnknownLightTypeAndNegativeExposure) {
  const std::string dir = good_capture(test::tmp_dir("set"));
  test::edit_json(dir + "/capture.json",
                  [](auto& j) { j["views"][0]["lights"][0]["type"] = "laser"; });
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"views[0].lights[0].type", "laser"},
                 dir + "/m.json");
  test::edit_json(dir + "/capture.json", [](auto& j) {
    j["views"][0]["lights"][0]["type"] = "point";
    j["views"][0]["exposure"] = -1;
  });
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"views[0].exposure"},
                 dir + "/m.json");
}

TEST(BadInput, MissingGeometryBuffer) {
  const std::string dir = good_capture(test::tmp_dir("set"));
  fs::remove(dir + "/geometry/all_N.exr");
  expect_failure("fit " + dir + " --out " + dir + "/m.json", {"geometry", "all_N.exr", "not found"},
                 dir + "/m.json");
}

TEST(BadInput, BadMaterialAndTable) {
  const std::string dir = test::tmp_dir("x");
  std::ofstream(dir + "/m.json")
      << R"({"format":"aniso-material","version":1,"kd":[0.1,0.1],"ks":0.5,"n":10,
                                       "fiber_angle_deg":0})";
  expect_failure("bake " + dir + "/m.json --out " + dir + "/bake", {"m.json", "kd"}, dir + "/bake");
  std::ofstream(dir + "/good.json")
      << R"({"format":"aniso-material","version":1,"kd":0.1,"ks":0.5,"n":10,
                                          "fiber_angle_deg":0})";
  std::ofstream(dir + "/t.csv") << "theta_i_deg,phi_i_deg,theta_o,phi_o_deg\n1,2,3,4\n";
  expect_failure("eval " + dir + "/good.json --table " + dir + "/t.csv --out " + dir + "/o.csv",
                 {"t.csv", "theta_o"}, dir + "/o.csv");
  expect_failure("preview " + dir + "/good.json --out " + dir + "/p.png --light 0,0,0", {"--light"},
                 dir + "/p.png");
}

// ANISO_GL picks the preview's renderer: an unknown value is an error naming it; "gpu" and
// "software" take that EGL device or say that EGL lists none (here a machine without a GPU, and
// with Mesa, lists llvmpipe alone; a GPU machine without Mesa the GPU alone).
TEST(BadInput, TheRendererAskedForIsNamed) {
  const std::string dir = test::tmp_dir("gl");
  std::ofstream(dir + "/m.json") << R"({"format":"aniso-material","version":1,"kd":0.1,"ks":0.5,
                                        "n":10,"fiber_angle_deg":0})";
  const std::string args = "$A preview " + dir + "/m.json --size 16 --out " + dir;
  test::RunResult r = test::sh("ANISO_GL=hardware " + args + "/a.png");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("ANISO_GL=hardware: expected auto, gpu or software"), std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir + "/a.png"));
  const test::RunResult a = test::sh("ANISO_GL=auto " + args + "/auto.png");
  ASSERT_EQ(a.status, 0) << a.output;
  const bool on_llvmpipe = a.output.find("on llvmpipe") != std::string::npos;
  // An asked-for renderer draws there (llvmpipe for software alone), or, where `may_lack`, fails
  // saying EGL lists none and writes nothing.
  auto check = [&](const std::string& want, const std::string& none, bool may_lack) {
    const test::RunResult w = test::sh("ANISO_GL=" + want + " " + args + "/" + want + ".png");
    if (w.status != 0) {
      EXPECT_TRUE(may_lack) << w.output;
      EXPECT_NE(w.output.find("ANISO_GL=" + want + ": " + none), std::string::npos) << w.output;
      EXPECT_FALSE(fs::exists(dir + "/" + want + ".png"));
      return false;
    }
    EXPECT_EQ(w.output.find("on llvmpipe") != std::string::npos, want == "software") << w.output;
    return true;
  };
  // Without a GPU (auto drew on llvmpipe) "gpu" must fail; with one it must draw there. Mesa's
  // llvmpipe is there where auto drew on it; a GPU machine may have no Mesa.
  EXPECT_EQ(check("gpu", "EGL lists no GPU device", on_llvmpipe), !on_llvmpipe);
  check("software", "EGL lists no software renderer", !on_llvmpipe);
}

TEST(BadInput, UnknownPresetAndOption) {
  const std::string dir = test::tmp_dir("x");
  expect_failure("synth velvet " + dir + "/set", {"velvet", "brushed-metal"}, dir + "/set");
  const test::RunResult r = test::run_cli("fit --frobnicate");
  EXPECT_NE(r.status, 0);
}

}  // namespace
}  // namespace aniso
