// A person's files are sacred (issue 8): what a command may replace, what it must refuse, and
// what a failed, killed or concurrent run leaves behind. Every case runs the real CLI.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "io/files.h"
#include "test_util.h"

namespace aniso {
namespace {

namespace fs = std::filesystem;

std::string slurp(const std::string& f) {
  std::ifstream in(f, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A folder with a material, a sample table, and a person's photo.
std::string workspace() {
  const std::string dir = test::tmp_dir("ws");
  std::ofstream(dir + "/m.json") << R"({"format": "aniso-material", "version": 1, "model": "line",
    "kd": [0.2, 0.15, 0.1], "ks": 0.6, "n": 40, "fiber_angle_deg": 30})";
  std::ofstream(dir + "/t.csv") << "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n30,0,30,180\n";
  std::ofstream(dir + "/photo.jpg") << "a person's photo";
  return dir;
}

bool leftover_temps(const std::string& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find("aniso-tmp") != std::string::npos) return true;
  return false;
}

TEST(Files, BakeIntoTheCurrentFolderHoldingOtherFilesIsRefused) {
  const std::string ws = workspace();
  const auto r = test::sh("cd " + ws + " && $A bake m.json --out .");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(ws + "/m.json"));
  EXPECT_EQ(slurp(ws + "/photo.jpg"), "a person's photo");
  // Even with --force: the folder holds the command's own input.
  const auto f = test::sh("cd " + ws + " && $A bake m.json --out . --force");
  EXPECT_NE(f.status, 0) << f.output;
  EXPECT_NE(f.output.find("input"), std::string::npos) << f.output;
  EXPECT_TRUE(fs::exists(ws + "/m.json"));
}

TEST(Files, BakeOverItsOwnInputIsRefused) {
  const std::string ws = workspace();
  const std::string before = slurp(ws + "/m.json");
  const auto r = test::sh("cd " + ws + " && $A bake m.json --out m.json --force");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("is an input"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::is_regular_file(ws + "/m.json"));
  EXPECT_EQ(slurp(ws + "/m.json"), before);
}

TEST(Files, SynthRefusesAFolderWithAPhotoUnlessForced) {
  const std::string ws = workspace();
  fs::create_directories(ws + "/shoot");
  std::ofstream(ws + "/shoot/IMG_0001.jpg") << "photo";
  const auto r = test::sh("$A synth brushed-metal " + ws + "/shoot --views 2 --size 16");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("IMG_0001.jpg"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(ws + "/shoot/IMG_0001.jpg"));
  const auto f = test::sh("$A synth brushed-metal " + ws + "/shoot --views 2 --size 16 --force");
  EXPECT_EQ(f.status, 0) << f.output;
  EXPECT_TRUE(fs::exists(ws + "/shoot/capture.json"));
  EXPECT_FALSE(fs::exists(ws + "/shoot/IMG_0001.jpg"));
}

// `bench --work` takes a new or empty folder, or one an earlier bench wrote (its marker): a folder
// of someone's files is refused before anything is written there (the bench replaces its sets
// and observation files run after run).
TEST(Files, BenchRefusesAWorkFolderOfSomeoneElsesFiles) {
  const std::string ws = workspace();
  const auto r = test::sh("cd " + ws + " && $A bench bake --quick --work . --out b.json");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("aniso did not write"), std::string::npos) << r.output;
  EXPECT_EQ(slurp(ws + "/photo.jpg"), "a person's photo");
  EXPECT_FALSE(fs::exists(ws + "/b.json"));
  EXPECT_FALSE(fs::exists(ws + "/" + kOutputMarker));
  // A new folder, then the same folder again: the bench's own.
  for (int run = 0; run < 2; ++run) {
    const auto ok = test::sh("cd " + ws + " && $A bench bake --quick --work bw --out b.json");
    EXPECT_EQ(ok.status, 0) << ok.output;
  }
  EXPECT_TRUE(fs::exists(ws + "/bw/" + kOutputMarker));
}

TEST(Files, AnEarlierOutputIsReplacedWhole) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 16").status, 0);
  EXPECT_TRUE(fs::exists(ws + "/b/.aniso-output"));
  std::ofstream(ws + "/b/stale.txt") << "left by hand";
  const auto r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 32");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_FALSE(fs::exists(ws + "/b/stale.txt"));  // replaced whole, not merged
  EXPECT_NE(slurp(ws + "/b/bake.json").find("--size 32"), std::string::npos);
  EXPECT_FALSE(leftover_temps(ws));
}

TEST(Files, DashAndDevStdoutStreamToStandardOutput) {
  const std::string ws = workspace();
  const auto r = test::sh("$A eval " + ws + "/m.json --table " + ws + "/t.csv --out - 2>/dev/null");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.rfind("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,r,g,b\n", 0), 0u)
      << r.output;
  const auto p = test::sh("$A eval " + ws + "/m.json --table " + ws +
                          "/t.csv --out /dev/stdout 2>/dev/null | wc -l");
  EXPECT_EQ(p.status, 0) << p.output;
  EXPECT_EQ(p.output, "2\n");
  EXPECT_TRUE(fs::is_symlink("/dev/stdout"));
  // Redirected to a file: written in place.
  const auto f = test::sh("$A eval " + ws + "/m.json --table " + ws +
                          "/t.csv --out /dev/stdout > " + ws + "/redirected.csv 2>/dev/null");
  EXPECT_EQ(f.status, 0) << f.output;
  EXPECT_NE(slurp(ws + "/redirected.csv").find(",r,g,b"), std::string::npos);
}

TEST(Files, DevicesAndFifosAreWrittenInPlaceNeverRenamedOver) {
  const std::string ws = workspace();
  const auto d = test::sh("$A eval " + ws + "/m.json --table " + ws + "/t.csv --out /dev/null");
  EXPECT_EQ(d.status, 0) << d.output;
  struct stat st;
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  const auto f = test::sh("cd " + ws + " && mkfifo pipe && (cat pipe > got.csv &) && $A eval " +
                          "m.json --table t.csv --out pipe && wait && sleep 0.2 && cat got.csv");
  EXPECT_EQ(f.status, 0) << f.output;
  EXPECT_NE(f.output.find(",r,g,b"), std::string::npos) << f.output;
  ASSERT_EQ(::stat((ws + "/pipe").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
}

TEST(Files, AFolderWhereAFileBelongsIsNamed) {
  const std::string ws = workspace();
  fs::create_directories(ws + "/outdir");
  const auto r =
      test::sh("$A eval " + ws + "/m.json --table " + ws + "/t.csv --out " + ws + "/outdir");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("is a folder"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("Success"), std::string::npos) << r.output;
}

TEST(Files, AReplacedFileKeepsItsMode) {
  const std::string ws = workspace();
  std::ofstream(ws + "/out.csv") << "old";
  fs::permissions(ws + "/out.csv", fs::perms::owner_read | fs::perms::owner_write);
  ASSERT_EQ(test::sh("$A eval " + ws + "/m.json --table " + ws + "/t.csv --out " + ws + "/out.csv")
                .status,
            0);
  EXPECT_EQ(fs::status(ws + "/out.csv").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_NE(slurp(ws + "/out.csv").find(",r,g,b"), std::string::npos);
}

TEST(Files, AFullDiskLeavesThePreviousOutputAsItWas) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A preview " + ws + "/m.json --out " + ws + "/p.png --size 64").status, 0);
  ASSERT_EQ(test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 64").status, 0);
  const std::string png = slurp(ws + "/p.png"), sidecar = slurp(ws + "/b/bake.json");
  // RLIMIT_FSIZE of 4 KiB stands in for a full disk (SIGXFSZ ignored: writes fail with EFBIG).
  const std::string limit = "trap '' XFSZ; ulimit -f 4; ";
  const auto p = test::sh(limit + "$A preview " + ws + "/m.json --out " + ws + "/p.png --size 256");
  EXPECT_NE(p.status, 0) << p.output;
  EXPECT_EQ(slurp(ws + "/p.png"), png);
  const auto b = test::sh(limit + "$A bake " + ws + "/m.json --out " + ws + "/b --size 256");
  EXPECT_NE(b.status, 0) << b.output;
  EXPECT_NE(b.output.find("what was there is kept"), std::string::npos) << b.output;
  EXPECT_EQ(slurp(ws + "/b/bake.json"), sidecar);
  EXPECT_FALSE(leftover_temps(ws));
}

TEST(Files, AKilledRunLeavesTheOldOutputAndItsTemporaryIsCleanedNextTime) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 16").status, 0);
  const std::string sidecar = slurp(ws + "/b/bake.json");
  // A large bake killed part way (or, on a fast machine, finished: then it is whole).
  test::sh("$A bake " + ws + "/m.json --out " + ws +
           "/b --size 2048 >/dev/null 2>&1 & pid=$!; sleep 0.4; kill -9 $pid; wait $pid");
  const std::string now = slurp(ws + "/b/bake.json");
  EXPECT_TRUE(now == sidecar || now.find("--size 2048") != std::string::npos);
  EXPECT_TRUE(fs::exists(ws + "/b/diffuse.exr"));
  ASSERT_EQ(test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 16").status, 0);
  EXPECT_FALSE(leftover_temps(ws));
}

TEST(Files, ConcurrentWritersToOneFolderBothSucceed) {
  const std::string ws = workspace();
  const auto r = test::sh("for i in 1 2 3 4; do $A bake " + ws + "/m.json --out " + ws +
                          "/b --size 64 >/dev/null & done; ok=0; for j in 1 2 3 4; do wait -n || "
                          "ok=1; done; exit $ok");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(ws + "/b/bake.json"));
  EXPECT_TRUE(fs::exists(ws + "/b/combined_16.png"));
  EXPECT_FALSE(leftover_temps(ws));
}

TEST(Files, InputsAreCheckedBeforeTheFitAndNothingIsWritten) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A synth brushed-metal " + ws + "/cap --views 2 --size 16").status, 0);
  const auto r =
      test::sh("$A fit " + ws + "/cap --truth " + ws + "/nope.json --out " + ws + "/fit.json");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("nope.json"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("iterations"), std::string::npos) << "the fit ran first: " << r.output;
  EXPECT_FALSE(fs::exists(ws + "/fit.json"));
  const auto o = test::sh("$A fit " + ws + "/cap --out " + ws + "/cap/capture.json");
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("is an input"), std::string::npos) << o.output;
}

TEST(Files, SpecialFilesAreNotReadAsInput) {
  const std::string ws = workspace();
  const auto f =
      test::sh("cd " + ws + " && mkdir cap && mkfifo cap/capture.json && timeout 10 $A " +
               "fit cap --out fit.json");
  EXPECT_EQ(f.status, 1) << f.output;  // not 124: it did not hang on the FIFO
  EXPECT_NE(f.output.find("not a regular file"), std::string::npos) << f.output;
  const auto z = test::sh("$A bake /dev/zero --out " + ws + "/b");
  EXPECT_EQ(z.status, 1) << z.output;
}

TEST(Files, UnknownSubcommandsAndOptionsGetADidYouMean) {
  const auto s = test::sh("$A fitt x");
  EXPECT_NE(s.status, 0);
  EXPECT_NE(s.output.find("did you mean 'fit'"), std::string::npos) << s.output;
  const auto o = test::sh("$A fit x --modle line --out y");
  EXPECT_NE(o.status, 0);
  EXPECT_NE(o.output.find("did you mean '--model'"), std::string::npos) << o.output;
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// Paths in a written file are relative to that file: a fitted material that uses the capture's
// topology map previews and bakes from anywhere, and the bake carries the map.
TEST(Files, AFittedMaterialNamesItsMapsRelativeToItselfAndTheBakeCarriesThem) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A synth silk-torus " + ws + "/torus --views 4 --size 32").status, 0);
  auto r = test::sh("$A fit " + ws + "/torus --model fiber --out " + ws + "/fitted/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(slurp(ws + "/fitted/m.json"));
  EXPECT_EQ(j["topology"]["map"], "../torus/maps/topology.png") << j["topology"].dump();
  r = test::sh("cd / && $A preview " + ws + "/fitted/m.json --out " + ws + "/p.png --size 48");
  EXPECT_EQ(r.status, 0) << r.output;
  r = test::sh("$A bake " + ws + "/fitted/m.json --out " + ws + "/b --size 16");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(ws + "/b/maps/topology.png"));
  const auto b = nlohmann::json::parse(slurp(ws + "/b/bake.json"));
  EXPECT_EQ(b["model"], "fiber");
  EXPECT_EQ(b["material"]["topology"]["map"], "maps/topology.png");
  // A missing map is an error naming the material and the key.
  fs::remove(ws + "/torus/maps/topology.png");
  r = test::sh("$A preview " + ws + "/fitted/m.json --out " + ws + "/p2.png --size 48");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("m.json: topology.map"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(ws + "/p2.png"));
}

TEST(Files, AMaterialWithAMapOfSPreviewsAndBakes) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A synth fiber-flat-map " + ws + "/set --views 4 --size 32").status, 0);
  auto r = test::sh("$A fit " + ws + "/set --model fiber --topology-map 4 --out " + ws + "/s.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::sh("$A preview " + ws + "/s.json --shape flat --out " + ws + "/p.png --size 64");
  ASSERT_EQ(r.status, 0) << r.output;
  // The GPU renders the same s per fragment as the CPU evaluation of the same tables.
  const auto pos = r.output.find("GPU vs the same tables on the CPU: ");
  ASSERT_NE(pos, std::string::npos) << r.output;
  EXPECT_LT(std::stod(r.output.substr(pos + 35)), 1e-3) << r.output;
  r = test::sh("$A bake " + ws + "/s.json --out " + ws + "/b --size 16");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(ws + "/b/maps/s_topology_s.exr"));
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

TEST(Files, AReadOnlyFolderGetsAClearErrorAndNothingHalfWritten) {
  if (::geteuid() == 0) {
    // root writes anywhere; a read-only bind is not available here, so stand in with a file
    // where the parent folder should be.
    const std::string ws = workspace();
    const auto r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/photo.jpg/b");
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("photo.jpg"), std::string::npos) << r.output;
    EXPECT_EQ(slurp(ws + "/photo.jpg"), "a person's photo");
    return;
  }
  const std::string ws = workspace();
  fs::create_directories(ws + "/ro");
  fs::permissions(ws + "/ro", fs::perms::owner_read | fs::perms::owner_exec);
  const auto r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/ro/b");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("ro/b"), std::string::npos) << r.output;
  fs::permissions(ws + "/ro", fs::perms::owner_all);
  EXPECT_TRUE(fs::is_empty(ws + "/ro"));
}

}  // namespace
}  // namespace aniso
