// fit --maps (issue 11): per-texel maps against ground truth, tiles and MPI ranks that give the
// untiled run's files byte for byte, and the texel LM against Ceres.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "datasets_synth/presets.h"
#include "fit/fit.h"
#include "io/files.h"
#include "io/image_io.h"
#include "io/material_io.h"
#include "models/material_maps.h"
#include "test_util.h"

namespace aniso {
namespace {

// --maps (issue 11): a plate whose brushing turns in circles and whose k_d changes across it,
// rendered with 1 % noise; every texel's psi and k_d against the truth maps at the texel centre.
TEST(FitMaps, SwirlPlateMapsMatchTheTruthPerTexel) {
  const std::string dir = test::tmp_dir("swirl");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 128x128");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --maps 16x16 --out " + dir + "/fit/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s", r.output.substr(0, r.output.find("fit: wrote")).c_str());
  const Material truth = read_material(dir + "/set/truth.json");
  const auto j = nlohmann::json::parse(read_text_file(dir + "/fit/m.json"));
  ASSERT_TRUE(j.contains("maps_uncertainty")) << j.dump();
  const Material fit = read_material(dir + "/fit/m.json");  // reads the maps back
  ASSERT_TRUE(fit.maps.fiber && fit.maps.kd && fit.maps.ks && fit.maps.n);
  const Image det =
      read_image(dir + "/fit/" + j["maps_uncertainty"]["determined"].get<std::string>()).image;
  const Image sig =
      read_image(dir + "/fit/" + j["maps_uncertainty"]["fiber"].get<std::string>()).image;
  std::vector<double> dpsi, dkd, z;
  size_t determined = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      if (det.at(x, y, 0) < 0.5) continue;
      ++determined;
      const double u = (x + 0.5) / 16, v = (y + 0.5) / 16;
      const Material t = material_at(truth, u, v), f = material_at(fit, u, v);
      double d = std::abs(f.fiber_angle_deg - t.fiber_angle_deg);
      d = std::min(d, 180 - d);
      // The swirl's centre, where psi turns by 90 degrees within a texel, is left out.
      if (std::hypot(u - 0.5, v - 0.5) > 0.1) {
        dpsi.push_back(d);
        z.push_back(d / std::max(sig.at(x, y, 0), 1e-6f));
      }
      dkd.push_back(std::abs(f.kd[0] / t.kd[0] - 1));
    }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? NAN : v[v.size() / 2];
  };
  std::printf(
      "maps: %zu of 256 texels determined; median |dpsi| %.3f deg (median |dpsi|/sigma %.2f), "
      "median |dkd.r|/kd.r %.2f %%\n",
      determined, median(dpsi), median(z), 100 * median(dkd));
  EXPECT_GT(determined, 200u);
  EXPECT_LT(median(dpsi), 1.0);
  EXPECT_LT(median(dkd), 0.03);
  EXPECT_LT(median(z), 3.0);  // the sigmas are not wildly overconfident
  // `aniso verify` renders with the maps: residual RMS near the noise (0.01); the global fit alone
  // left 0.11.
  r = test::run_cli("verify " + dir + "/set " + dir + "/fit/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto at = r.output.find("\nall ");
  ASSERT_NE(at, std::string::npos) << r.output;
  std::istringstream all(r.output.substr(at + 5));
  double pixels = 0, rms = 0;
  all >> pixels >> rms;
  std::printf("verify with the fitted maps: residual RMS %.4f over %.0f pixels\n", rms, pixels);
  EXPECT_LT(rms, 0.025);
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// --tile i/N and `aniso merge`: three tiles joined give the untiled run's map files byte for byte;
// a missing or foreign tile is refused.
TEST(FitMaps, TilesMergeIntoTheUntiledMapsByteForByte) {
  const std::string dir = test::tmp_dir("tiles");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --out " + dir + "/whole.json");
  ASSERT_EQ(r.status, 0) << r.output;
  std::string tiles;
  for (int i = 0; i < 3; ++i) {
    const std::string t = dir + "/t" + std::to_string(i) + ".json";
    r = test::run_cli("fit " + dir + "/set --maps 8x6 --tile " + std::to_string(i) + "/3 --out " +
                      t);
    ASSERT_EQ(r.status, 0) << r.output;
    tiles += " " + t;
  }
  r = test::run_cli("merge" + tiles + " --out " + dir + "/merged.json");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* k : {"kd", "ks", "n", "fiber", "kd_sigma", "ks_sigma", "n_sigma", "fiber_sigma",
                        "coverage", "determined"}) {
    const std::string a = read_text_file(dir + "/whole_" + k + ".exr");
    const std::string b = read_text_file(dir + "/merged_" + k + ".exr");
    EXPECT_TRUE(a == b) << k << ": the merged map differs from the untiled one";
  }
  const Material m = read_material(dir + "/merged.json");
  EXPECT_TRUE(m.maps.fiber && m.maps.kd);
  // The Slurm job-array script, run here task after task, gives the same maps.
  r = test::sh("ANISO=\"$A\" " + std::string(ANISO_SOURCE_DIR) + "/scripts/slurm_maps.sh local " +
               dir + "/set 8x6 3 " + dir + "/slurm");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(read_text_file(dir + "/slurm/material_fiber.exr") ==
              read_text_file(dir + "/whole_fiber.exr"));
  r = test::run_cli("merge " + dir + "/t0.json " + dir + "/t2.json --out " + dir + "/bad.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("tile 1 of 3 is missing"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.json"));
  r = test::run_cli("merge" + tiles + " " + dir + "/t1.json --out " + dir + "/bad.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("repeated"), std::string::npos) << r.output;
  r = test::run_cli("fit " + dir + "/set --tile 0/2 --out " + dir + "/x.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("--maps"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// `aniso fit --maps --mpi` under `mpirun -np 2` (Open MPI on loopback): rank i fits tile i/2,
// rank 0 merges; the map files equal an untiled run's byte for byte. The plain binary hands over
// to aniso-mpi; without MPI the option says how to get it.
TEST(FitMaps, MpiRanksFitTheTilesAndRankZeroMerges) {
#ifndef ANISO_MPI_BIN
  GTEST_SKIP() << "built without -DANISO_MPI=ON (scripts/build.sh turns it on)";
#else
  const std::string dir = test::tmp_dir("mpi");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --out " + dir + "/whole.json");
  ASSERT_EQ(r.status, 0) << r.output;
  // As root, mpirun needs to be told; two ranks on two cores may oversubscribe.
  const std::string mpirun =
      "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,tcp "
      "OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_oob_tcp_if_include=lo mpirun --oversubscribe -np 2 ";
  r = test::sh(mpirun + "\"$A\" fit " + dir + "/set --maps 8x6 --mpi --out " + dir + "/mpi.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("fit --mpi: 2 ranks"), std::string::npos) << r.output;
  for (const char* k : {"kd", "ks", "n", "fiber", "fiber_sigma", "coverage", "determined"})
    EXPECT_TRUE(read_text_file(dir + "/whole_" + k + ".exr") ==
                read_text_file(dir + "/mpi_" + k + ".exr"))
        << k << ": the MPI run's map differs from the untiled one";
  // A mistake is said once, by rank 0, and nothing is written.
  r = test::sh(mpirun + "\"$A\" fit " + dir + "/set --mpi --out " + dir + "/bad.json");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("give --maps"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.json"));
#endif
}

// The fast path of --maps (a hand-written Levenberg-Marquardt per texel) against Ceres, the
// fitter of record, on the same texels: the same minimum within a tenth of sigma everywhere.
TEST(FitMaps, LevenbergMarquardtReachesCeresMinimumPerTexel) {
  const std::string dir = test::tmp_dir("lm");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const std::string solver : {"lm", "ceres"}) {
    r = test::run_cli("fit " + dir + "/set --maps 8x6 --maps-solver " + solver + " --out " + dir +
                      "/" + solver + ".json");
    ASSERT_EQ(r.status, 0) << r.output;
    std::printf("%s: %s", solver.c_str(),
                r.output.substr(r.output.find("fit: --maps")).substr(0, 100).c_str());
    std::printf("\n");
  }
  auto img = [&](const std::string& solver, const char* key) {
    return read_image(dir + "/" + solver + "_" + key + ".exr").image;
  };
  const Image det = img("ceres", "determined");
  double worst = 0;
  size_t compared = 0;
  for (const char* key : {"kd", "ks", "n"}) {
    const Image a = img("lm", key), b = img("ceres", key),
                s = img("ceres", (std::string(key) + "_sigma").c_str());
    for (size_t i = 0; i < a.px.size(); ++i) {
      if (det.px[i / a.channels] < 0.5) continue;
      worst = std::max(worst, std::abs(double(a.px[i]) - b.px[i]) / s.px[i]);
      ++compared;
    }
  }
  const Image fa = img("lm", "fiber"), fb = img("ceres", "fiber"), fs = img("ceres", "fiber_sigma");
  for (size_t t = 0; t < fs.px.size(); ++t) {
    if (det.px[t] < 0.5) continue;
    const double pa = 0.5 * std::atan2(fa.px[2 * t + 1], fa.px[2 * t]);
    const double pb = 0.5 * std::atan2(fb.px[2 * t + 1], fb.px[2 * t]);
    double d = std::abs(pa - pb) * 180 / M_PI;
    d = std::min(d, 180 - d);
    worst = std::max(worst, d / fs.px[t]);
    ++compared;
  }
  std::printf("LM against Ceres: %zu numbers compared, worst difference %.4f sigma\n", compared,
              worst);
  EXPECT_GT(compared, 300u);
  EXPECT_LT(worst, 0.1);
}

}  // namespace
}  // namespace aniso
