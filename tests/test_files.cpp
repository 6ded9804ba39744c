// A person's files are sacred: what a command may replace, what it must refuse, and
// what a failed, killed or concurrent run leaves behind. Every case runs the real CLI.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "io/files/files.h"
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
  // --force moves the person's folder aside whole and says where: nothing is deleted.
  const auto f = test::sh("$A synth brushed-metal " + ws + "/shoot --views 2 --size 16 --force");
  EXPECT_EQ(f.status, 0) << f.output;
  EXPECT_TRUE(fs::exists(ws + "/shoot/capture.json"));
  EXPECT_FALSE(fs::exists(ws + "/shoot/IMG_0001.jpg"));
  EXPECT_EQ(slurp(ws + "/shoot.aniso-old-1/IMG_0001.jpg"), "photo");
  EXPECT_NE(f.output.find("shoot.aniso-old-1"), std::string::npos) << f.output;
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

// An earlier output of the same kind that holds exactly what aniso wrote is replaced whole; a
// file a person put there since, or one changed since, is refused by name; --force then moves
// just those aside (aniso's own files of the earlier output go).
TEST(Files, AnEarlierOutputIsReplacedWhole) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 16").status, 0);
  const auto marker = nlohmann::json::parse(slurp(ws + "/b/.aniso-output"));
  EXPECT_EQ(marker["kind"], "bake");
  EXPECT_GE(marker["files"].size(), 5u);
  auto r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 32");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(slurp(ws + "/b/bake.json").find("--size 32"), std::string::npos);
  std::ofstream(ws + "/b/NOTES.txt") << "left by hand";
  r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 16");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("'NOTES.txt', which aniso did not write"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--force to move it aside to"), std::string::npos) << r.output;
  EXPECT_NE(slurp(ws + "/b/bake.json").find("--size 32"), std::string::npos);
  fs::remove(ws + "/b/NOTES.txt");
  std::ofstream(ws + "/b/bake.json", std::ios::app) << " ";  // edited by hand
  r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 16");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("'bake.json', changed since aniso wrote it"), std::string::npos)
      << r.output;
  std::ofstream(ws + "/b/NOTES.txt") << "left by hand";
  r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/b --size 16 --force");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(slurp(ws + "/b/bake.json").find("--size 16"), std::string::npos);
  // Aside: only what aniso did not write as it was (the note, the edited sidecar).
  std::vector<std::string> aside;
  for (const auto& e : fs::directory_iterator(ws + "/b.aniso-old-1"))
    aside.push_back(e.path().filename().string());
  std::sort(aside.begin(), aside.end());
  EXPECT_EQ(aside, (std::vector<std::string>{"NOTES.txt", "bake.json"}));
  EXPECT_EQ(slurp(ws + "/b.aniso-old-1/NOTES.txt"), "left by hand");
  EXPECT_FALSE(leftover_temps(ws));
}

// An output never replaces one of another kind: a bake slipped onto a capture is refused, even
// where the capture is untouched; --force moves the capture aside whole.
TEST(Files, AnOutputOfAnotherKindIsRefused) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A synth brushed-metal " + ws + "/cap --views 2 --size 16").status, 0);
  const std::string capture = slurp(ws + "/cap/capture.json");
  auto r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/cap --size 16");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("is an aniso capture output, not a bake output"), std::string::npos)
      << r.output;
  EXPECT_EQ(slurp(ws + "/cap/capture.json"), capture);
  r = test::sh("$A export " + ws + "/m.json --out " + ws + "/cap");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_EQ(slurp(ws + "/cap/capture.json"), capture);
  // --force: the capture, aniso's own files of another kind, moves aside whole.
  r = test::sh("$A bake " + ws + "/m.json --out " + ws + "/cap --size 16 --force");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(ws + "/cap/bake.json"));
  EXPECT_EQ(slurp(ws + "/cap.aniso-old-1/capture.json"), capture);
  EXPECT_TRUE(fs::exists(ws + "/cap.aniso-old-1/" + kOutputMarker));
  // A game project's folder: refused; --force moves the project aside, never deletes it.
  fs::create_directories(ws + "/game/scenes");
  std::ofstream(ws + "/game/project.godot") << "[application]";
  std::ofstream(ws + "/game/scenes/main.tscn") << "[gd_scene]";
  r = test::sh("$A export " + ws + "/m.json --out " + ws + "/game");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("aniso did not write"), std::string::npos) << r.output;
  r = test::sh("$A export " + ws + "/m.json --out " + ws + "/game --force --size 16");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(ws + "/game/export.json"));
  EXPECT_EQ(slurp(ws + "/game.aniso-old-1/project.godot"), "[application]");
  EXPECT_EQ(slurp(ws + "/game.aniso-old-1/scenes/main.tscn"), "[gd_scene]");
  // The export records the command as a person can share it: no path of this machine.
  const auto e = nlohmann::json::parse(slurp(ws + "/game/export.json"));
  const std::string command = e["command"];
  EXPECT_EQ(command.rfind("aniso export ../m.json --out . ", 0), 0u) << command;
  EXPECT_EQ(command.find(ws), std::string::npos) << command;
}

// A file output replaces only a file aniso wrote as the same kind: not a person's shoot, not a
// board, not a table; --force moves it aside (NAME.aniso-old-N.EXT), keeping its bytes.
TEST(Files, AFileOutputNeverReplacesAnotherKindOrAPersonsFile) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A synth brushed-metal " + ws + "/cap --views 3 --size 24").status, 0);
  std::ofstream(ws + "/shoot.json") << "{\"measured\": \"by hand\"}";
  auto r = test::sh("$A fit " + ws + "/cap --out " + ws + "/shoot.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("shoot.json: exists and was not written by aniso as a material"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("iterations"), std::string::npos) << r.output;  // refused before the fit
  EXPECT_EQ(slurp(ws + "/shoot.json"), "{\"measured\": \"by hand\"}");
  // Its own material: replaced.
  ASSERT_EQ(test::sh("$A fit " + ws + "/cap --out " + ws + "/fit.json").status, 0);
  r = test::sh("$A fit " + ws + "/cap --out " + ws + "/fit.json");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(slurp(ws + "/fit.json"))["written_by"], "aniso material");
  // A board is not a preview.
  ASSERT_EQ(test::sh("$A board --out " + ws + "/board/board.png --dpi 50").status, 0);
  const std::string board = slurp(ws + "/board/board.png");
  r = test::sh("$A preview " + ws + "/m.json --out " + ws + "/board/board.png --size 32");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("is an aniso board, not a preview"), std::string::npos) << r.output;
  EXPECT_EQ(slurp(ws + "/board/board.png"), board);
  // The shoot skeleton a person fills in is never replaced by another board run.
  r = test::sh("$A board --out " + ws + "/board/board2.png --dpi 50 --shoot " + ws +
               "/board/shoot.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("may hold your measurements"), std::string::npos) << r.output;
  r = test::sh("$A preview " + ws + "/m.json --out " + ws + "/board/board.png --size 32 --force");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(slurp(ws + "/board/board.aniso-old-1.png"), board);
  EXPECT_NE(r.output.find("board.aniso-old-1.png"), std::string::npos) << r.output;
  // A table carries no stamp: an existing one is refused, moved aside with --force.
  std::ofstream(ws + "/measured.csv") << "mine";
  r = test::sh("$A eval " + ws + "/m.json --table " + ws + "/t.csv --out " + ws + "/measured.csv");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_EQ(slurp(ws + "/measured.csv"), "mine");
}

// preview writes the format its name says, or refuses; a JPEG is a JPEG.
TEST(Files, PreviewWritesTheFormatItsNameSays) {
  const std::string ws = workspace();
  auto r = test::sh("$A preview " + ws + "/m.json --out " + ws + "/p.jpg --size 32");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string jpg = slurp(ws + "/p.jpg");
  ASSERT_GT(jpg.size(), 4u);
  EXPECT_EQ(jpg.substr(0, 3), "\xFF\xD8\xFF");
  EXPECT_EQ(stamped_kind(ws + "/p.jpg"), "preview");
  r = test::sh("$A preview " + ws + "/m.json --out " + ws + "/p.jpg --size 32");  // its own
  EXPECT_EQ(r.status, 0) << r.output;
  r = test::sh("$A preview " + ws + "/m.json --out " + ws + "/p.tif --size 32");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find(".png (8-bit sRGB), .jpg (sRGB) or .exr"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(ws + "/p.tif"));
}

// Where the output cannot be written, the command says so before the work, not after it.
TEST(Files, OutputsAreCheckedForWritingBeforeTheWork) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A synth brushed-metal " + ws + "/cap --views 3 --size 24").status, 0);
  auto f = test::sh("$A fit " + ws + "/cap --out " + ws + "/photo.jpg/m.json");
  EXPECT_EQ(f.status, 1) << f.output;
  EXPECT_NE(f.output.find("photo.jpg is not a folder"), std::string::npos) << f.output;
  EXPECT_EQ(f.output.find("iterations"), std::string::npos) << f.output;
  f = test::sh("$A bake " + ws + "/m.json --out " + ws + "/photo.jpg/b");
  EXPECT_EQ(f.status, 1) << f.output;
  EXPECT_NE(f.output.find("photo.jpg is not a folder"), std::string::npos) << f.output;
  if (::geteuid() == 0) return;  // root writes in a read-only folder
  fs::create_directories(ws + "/locked");
  fs::permissions(ws + "/locked", fs::perms::owner_read | fs::perms::owner_exec);
  auto r = test::sh("$A fit " + ws + "/cap --out " + ws + "/locked/sub/m.json");
  fs::permissions(ws + "/locked", fs::perms::owner_all);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no permission to write in"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("iterations"), std::string::npos) << r.output;
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

// (A table carries no stamp: --force, which moves the old one aside, then writes the new one
// with the old one's mode.)
TEST(Files, AReplacedFileKeepsItsMode) {
  const std::string ws = workspace();
  std::ofstream(ws + "/out.csv") << "old";
  fs::permissions(ws + "/out.csv", fs::perms::owner_read | fs::perms::owner_write);
  ASSERT_EQ(test::sh("$A eval " + ws + "/m.json --table " + ws + "/t.csv --out " + ws +
                     "/out.csv --force")
                .status,
            0);
  EXPECT_EQ(slurp(ws + "/out.aniso-old-1.csv"), "old");
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
  // A value outside an option's set: the set and the closest value, exit 2 as for any mistyping.
  const auto v = test::sh("$A fit x --model fibre --out y");
  EXPECT_EQ(v.status, 2) << v.output;
  EXPECT_NE(v.output.find("--model: 'fibre' is not one of"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("did you mean 'fiber'"), std::string::npos) << v.output;
  EXPECT_EQ(v.output.find("FAILED"), std::string::npos) << v.output;
  const auto l = test::sh("$A fit x --loss hubber --out y");
  EXPECT_EQ(l.status, 2) << l.output;
  EXPECT_NE(l.output.find("did you mean 'huber'"), std::string::npos) << l.output;
}

// A JPEG cut short (a copy that stopped) is refused, naming the file: libjpeg would decode on and
// fill the rest with grey.
TEST(Files, ATruncatedJpegIsRefusedByName) {
  const std::string ws = workspace();
  ASSERT_EQ(test::sh("$A preview " + ws + "/m.json --out " + ws + "/p.jpg --size 64").status, 0);
  const std::string whole = slurp(ws + "/p.jpg");
  std::ofstream(ws + "/cut.jpg", std::ios::binary) << whole.substr(0, whole.size() * 3 / 4);
  ASSERT_EQ(test::sh("$A synth brushed-metal " + ws + "/cap --views 2 --size 64").status, 0);
  test::edit_json(ws + "/cap/capture.json", [&](auto& j) {
    j["views"][0]["image"] = ws + "/cut.jpg";
    j["color"] = {{"encoding", "srgb"}};
  });
  const auto r = test::sh("$A fit " + ws + "/cap --out " + ws + "/f.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("cut.jpg: damaged JPEG"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("Premature end of JPEG file\n"), std::string::npos) << r.output;
}

// Force is an output's own, given where it is claimed: in one process, a file and a folder claimed
// with it move what is in their way aside; another file and folder claimed without it are refused,
// and the library's own check of a folder (before it writes) keeps the force the command gave.
TEST(Files, ForceBelongsToTheOutputThatWasGivenIt) {
  const std::string ws = workspace();
  std::ofstream(ws + "/mine.png") << "a person's picture";
  std::ofstream(ws + "/theirs.png") << "another picture";
  fs::create_directories(ws + "/forced");
  std::ofstream(ws + "/forced/notes.txt") << "notes";
  fs::create_directories(ws + "/kept");
  std::ofstream(ws + "/kept/notes.txt") << "notes";

  check_output_file(ws + "/mine.png", OutputKind::kPreview, true);
  EXPECT_THROW(check_output_file(ws + "/theirs.png", OutputKind::kPreview), Error);
  check_output_folder(ws + "/forced", OutputKind::kBake, true);
  EXPECT_THROW(check_output_folder(ws + "/kept", OutputKind::kBake), Error);

  write_atomically(ws + "/mine.png", [](const std::string& p) { std::ofstream(p) << "new"; });
  EXPECT_EQ(slurp(ws + "/mine.png"), "new");
  EXPECT_EQ(slurp(ws + "/mine.aniso-old-1.png"), "a person's picture");
  // Written without a claim's force, the person's file stays and the new one is kept beside it.
  check_output_file(ws + "/other.png", OutputKind::kPreview);
  std::ofstream(ws + "/other.png") << "came meanwhile";
  EXPECT_THROW(
      write_atomically(ws + "/other.png", [](const std::string& p) { std::ofstream(p) << "new"; }),
      Error);
  EXPECT_EQ(slurp(ws + "/other.png"), "came meanwhile");

  const auto fill = [](const std::string& dir) { std::ofstream(dir + "/t.txt") << "table"; };
  write_folder_atomically(ws + "/forced", OutputKind::kBake, fill);  // checks again: keeps force
  EXPECT_EQ(slurp(ws + "/forced/t.txt"), "table");
  bool aside = false;
  for (const auto& e : fs::directory_iterator(ws))
    aside = aside || (e.path().filename().string().find("forced.aniso-old") == 0 &&
                      slurp((e.path() / "notes.txt").string()) == "notes");
  EXPECT_TRUE(aside) << "the person's folder was moved aside whole";
  EXPECT_THROW(write_folder_atomically(ws + "/kept", OutputKind::kBake, fill), Error);
  EXPECT_EQ(slurp(ws + "/kept/notes.txt"), "notes");
  EXPECT_FALSE(fs::exists(ws + "/kept/t.txt"));
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
  bool carried = false;  // the material's map of s (s_topology_s.GEN.exr) travels with the bake
  for (const auto& e : fs::directory_iterator(ws + "/b/maps"))
    carried = carried || e.path().filename().string().rfind("s_topology_s.", 0) == 0;
  EXPECT_TRUE(carried);
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
