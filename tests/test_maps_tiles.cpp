// fit --maps past one machine: tiles (`--tile i/N`, `aniso merge`), tiles from a given
// global fit that keep only their rows (`--global`), the Slurm script and MPI ranks, each against
// one untiled run byte for byte.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "io/files/files.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "test_util.h"

namespace aniso {
namespace {

// --tile i/N and `aniso merge`: three tiles joined give the untiled run's map files byte for byte;
// a missing or foreign tile is refused; --threads 1 gives the same bytes on one thread. (The Slurm
// script: FitMaps.TilesGivenTheGlobalFit...)
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
                        "coverage", "determined", "residual"}) {
    const std::string a = read_text_file(test::map_of(dir + "/whole", k));
    const std::string b = read_text_file(test::map_of(dir + "/merged", k));
    EXPECT_TRUE(a == b) << k << ": the merged map differs from the untiled one";
  }
  const Material m = read_material(dir + "/merged.json");
  EXPECT_TRUE(m.maps.fiber && m.maps.kd);
  // Its time is the tiles' work: their sum, each tile's own beside it (it was tile 0's alone).
  {
    const auto merged = nlohmann::json::parse(read_text_file(dir + "/merged.json"))["report"];
    double sum = 0, load = 0;
    for (int i = 0; i < 3; ++i) {
      const auto t =
          nlohmann::json::parse(read_text_file(dir + "/t" + std::to_string(i) + ".json"));
      const auto& tr = t["fit"]["report"];
      EXPECT_EQ(merged["tile_time_s"][i].get<double>(), tr["time_s"].get<double>());
      sum += tr["time_s"].get<double>();
      load += tr["time_breakdown_s"]["load"].get<double>();
    }
    EXPECT_NEAR(merged["time_s"].get<double>(), sum, 1e-12 * sum);
    EXPECT_NEAR(merged["time_breakdown_s"]["load"].get<double>(), load, 1e-12 * load);
  }
  // The merged report counts the whole grid's texels, as the untiled run's does (it held tile 0's
  // warnings: 10 texels the model does not describe, where the untiled run named 40 of 48).
  auto maps_said = [](const std::string& path) {
    const auto j = nlohmann::json::parse(read_text_file(path));
    std::vector<std::string> said;
    for (const auto& w : j["report"]["warnings"])
      if (w.get<std::string>().rfind("--maps: ", 0) == 0) said.push_back(w.get<std::string>());
    said.push_back("misfit " + j["report"]["maps_misfit_texels"].dump());
    return said;
  };
  const std::vector<std::string> whole_said = maps_said(dir + "/whole.json");
  EXPECT_GE(whole_said.size(), 2u);  // a warning, and the count
  EXPECT_EQ(maps_said(dir + "/merged.json"), whole_said);
  // --threads holds for the texels too (they ran on every core of the machine), with the same
  // maps byte for byte.
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --threads 1 --out " + dir + "/one.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto one = nlohmann::json::parse(read_text_file(dir + "/one.json"));
  EXPECT_EQ(one["report"]["maps_threads"], 1);
  for (const char* k : {"kd", "n", "fiber", "coverage"})
    EXPECT_TRUE(read_text_file(test::map_of(dir + "/whole", k)) ==
                read_text_file(test::map_of(dir + "/one", k)))
        << k;
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

// A sphere's uv leaves texel rows without a pixel (the far side of the ball): a tile of only such
// rows writes its tile, every texel undetermined, and says why, instead of failing for want of
// observations (which failed an MPI job or a Slurm array on any sphere, torus or disc); the merge
// is still the untiled run byte for byte, as are 16 bands of one row, the last ones empty.
TEST(FitMaps, ATileWhoseRowsNoPixelReachesIsWrittenUndetermined) {
  const std::string dir = test::tmp_dir("tiles");
  auto r = test::run_cli("synth satin-ball " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --subsample 2 --keep-anisotropic --out " + dir +
                    "/global.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string maps = " --maps 16x16 --global " + dir + "/global.json";
  r = test::run_cli("fit " + dir + "/set" + maps + " --out " + dir + "/whole.json");
  ASSERT_EQ(r.status, 0) << r.output;
  std::string tiles;
  for (int i = 0; i < 4; ++i) {
    const std::string t = dir + "/t" + std::to_string(i) + ".json";
    r = test::run_cli("fit " + dir + "/set" + maps + " --tile " + std::to_string(i) + "/4 --out " +
                      t);
    ASSERT_EQ(r.status, 0) << r.output;
    if (i == 3) {
      EXPECT_NE(r.output.find("0 texels solved"), std::string::npos) << r.output;
      EXPECT_NE(r.output.find("no usable pixel's uv falls in its texel rows"), std::string::npos)
          << r.output;
    }
    tiles += " " + t;
  }
  r = test::run_cli("merge" + tiles + " --out " + dir + "/merged.json");
  ASSERT_EQ(r.status, 0) << r.output;
  // In bands of --maps-memory 0.3 MB (the records ~1.2 MB in all): the bands' rows follow the
  // pixels' uv, so no band holds more than that, the pixels its 8 views share while they load
  // included. Four bands of equal rows held 0.4 MB in one; a plan of the records alone 0.33 MB.
  r = test::run_cli("fit " + dir + "/set" + maps + " --maps-memory 0.3 --out " + dir +
                    "/bands.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("bands of texel rows"), std::string::npos) << r.output;
  const auto rep = nlohmann::json::parse(read_text_file(dir + "/bands.json"))["report"];
  EXPECT_GT(rep["maps_bands"].get<int>(), 2);
  EXPECT_GT(rep["maps_band_peak_bytes"].get<double>(), 0.1e6);
  EXPECT_LE(rep["maps_band_peak_bytes"].get<double>(), 0.3e6);
  EXPECT_GT(rep["maps_band_shared_bytes"].get<double>(), 0.02e6);
  for (const char* k :
       {"kd", "ks", "n", "fiber", "kd_sigma", "n_sigma", "coverage", "determined"}) {
    const std::string a = read_text_file(test::map_of(dir + "/whole", k));
    EXPECT_TRUE(a == read_text_file(test::map_of(dir + "/merged", k))) << k << ": merged";
    EXPECT_TRUE(a == read_text_file(test::map_of(dir + "/bands", k))) << k << ": bands";
  }
  // A capture with no usable pixel at all is still refused.
  r = test::run_cli("fit " + dir + "/set" + maps + " --out " + dir + "/x.json --subsample 1024");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no usable observations"), std::string::npos) << r.output;
}

// --global with --tile: the global fit comes from an earlier run (here on a subsample) and each
// tile keeps only the pixels whose uv falls in its rows and its --smooth band: its records are its
// share of the sample, and the merge still equals an untiled run with that global fit, byte for
// byte; the Slurm script does the same. --global without --maps, or of the other model, is
// refused, and one of another capture named in a warning.
TEST(FitMaps, TilesGivenTheGlobalFitKeepOnlyTheirRows) {
  const std::string dir = test::tmp_dir("global");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --subsample 2 --out " + dir + "/global.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string maps = " --maps 8x6 --global " + dir + "/global.json";
  r = test::run_cli("fit " + dir + "/set" + maps + " --smooth 1 --smooth-sweeps 1 --out " + dir +
                    "/whole.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("global fit from"), std::string::npos) << r.output;
  auto report = [](const std::string& f, bool tile) {
    const auto j = nlohmann::json::parse(read_text_file(f));
    return tile ? j["fit"]["report"] : j["report"];
  };
  const size_t total = report(dir + "/whole.json", false)["pixels"];
  std::string tiles;
  for (int i = 0; i < 3; ++i) {
    const std::string t = dir + "/t" + std::to_string(i) + ".json";
    r = test::run_cli("fit " + dir + "/set" + maps + " --smooth 1 --smooth-sweeps 1 --tile " +
                      std::to_string(i) + "/3 --out " + t);
    ASSERT_EQ(r.status, 0) << r.output;
    const auto rep = report(t, true);
    const size_t kept = rep["pixels"], outside = rep["skipped"]["outside_tile"];
    // The implausible-value limit is the global fit's, not one from the tile's own rows.
    EXPECT_EQ(rep.value("implausible_limit", 0.0),
              report(dir + "/global.json", false).value("implausible_limit", -1.0));
    std::printf("tile %d/3 (with its smoothing band): %zu of %zu pixels\n", i, kept, total);
    EXPECT_LT(kept, total * 3 / 4);
    EXPECT_EQ(kept + outside, total);
    tiles += " " + t;
  }
  r = test::run_cli("merge" + tiles + " --out " + dir + "/merged.json");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* k :
       {"kd", "ks", "n", "fiber", "kd_sigma", "fiber_sigma", "coverage", "determined"})
    EXPECT_TRUE(read_text_file(test::map_of(dir + "/whole", k)) ==
                read_text_file(test::map_of(dir + "/merged", k)))
        << k << ": the merged map differs from the untiled one";
  // The merged material's scalars are the maps' means, as the untiled run's; the global fit it
  // was given is its report.global.
  EXPECT_EQ(read_material(dir + "/merged.json").kd, read_material(dir + "/whole.json").kd);
  EXPECT_NE(read_material(dir + "/merged.json").kd, read_material(dir + "/global.json").kd);
  EXPECT_EQ(nlohmann::json::parse(read_text_file(dir + "/merged.json"))["report"]["global"]["kd"],
            nlohmann::json::parse(read_text_file(dir + "/global.json"))["kd"]);
  // Each tile counted its own rows' pixels: the merged report counts the untiled run's (it said
  // tile 0's).
  const auto merged_rep = report(dir + "/merged.json", false);
  const auto whole_rep = report(dir + "/whole.json", false);
  for (const char* k : {"pixels", "observations", "skipped"})
    EXPECT_EQ(merged_rep[k], whole_rep[k]) << k;
  // The Slurm script (a global fit, a job array of tiles from it, a merge), run here job after
  // job, gives the same maps.
  r = test::sh("ANISO=\"$A\" GLOBAL_SUBSAMPLE=2 FIT_OPTIONS='--smooth 1 --smooth-sweeps 1' " +
               std::string(ANISO_SOURCE_DIR) + "/scripts/slurm_maps.sh local " + dir +
               "/set 8x6 3 " + dir + "/slurm");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(read_text_file(test::map_of(dir + "/slurm/material", "fiber")) ==
              read_text_file(test::map_of(dir + "/whole", "fiber")));
  r = test::run_cli("fit " + dir + "/set --global " + dir + "/global.json --out " + dir +
                    "/x.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("give --maps"), std::string::npos) << r.output;
  // A global fit of another capture (here: a file that says 99 views) is named in a warning.
  auto other = nlohmann::json::parse(read_text_file(dir + "/global.json"));
  other["report"]["views"] = 99;
  write_text_file(dir + "/other.json", other.dump());
  r = test::run_cli("fit " + dir + "/set --maps 4x4 --global " + dir + "/other.json --out " + dir +
                    "/o.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("was fitted on 99 views; this capture has 8"), std::string::npos)
      << r.output;
  r = test::run_cli("fit " + dir + "/set" + maps + " --model fiber --out " + dir + "/x.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("is a line model fit"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.json"));
}

// Without smoothing the tiles' rows do not overlap: their pixels add up to the whole set's; from
// the full global fit's file (line model, and fiber model with its s and quadrature order) the
// tiles reproduce the plain untiled run byte for byte.
TEST(FitMaps, TilesFromAFullGlobalFitReproduceThePlainRun) {
  const std::string dir = test::tmp_dir("global_full");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  auto report = [](const std::string& f) {
    return nlohmann::json::parse(read_text_file(f))["fit"]["report"];
  };
  r = test::run_cli("fit " + dir + "/set --keep-anisotropic --out " + dir + "/full.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --out " + dir + "/plain.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const size_t total =
      nlohmann::json::parse(read_text_file(dir + "/plain.json"))["report"]["pixels"];
  size_t sum = 0;
  for (int i = 0; i < 2; ++i) {
    const std::string t = dir + "/p" + std::to_string(i) + ".json";
    r = test::run_cli("fit " + dir + "/set --maps 8x6 --global " + dir + "/full.json --tile " +
                      std::to_string(i) + "/2 --out " + t);
    ASSERT_EQ(r.status, 0) << r.output;
    sum += report(t)["pixels"].get<size_t>();
  }
  EXPECT_EQ(sum, total);
  r = test::run_cli("merge " + dir + "/p0.json " + dir + "/p1.json --out " + dir + "/pm.json");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* k : {"kd", "ks", "n", "fiber", "kd_sigma", "fiber_sigma", "determined"})
    EXPECT_TRUE(read_text_file(test::map_of(dir + "/plain", k)) ==
                read_text_file(test::map_of(dir + "/pm", k)))
        << k << ": tiles from the full global fit differ from the plain untiled run";
  // The fiber model: its tiles take the global fit's s, quadrature order and quadrature errors
  // (each texel starts from its k_d, k_s, n and s, and takes the lowest order its own values
  // allow: here order 3 where the global fit took 4) and reproduce the plain untiled run byte for
  // byte.
  r = test::run_cli("fit " + dir + "/set --model fiber --subsample 4 --keep-anisotropic --out " +
                    dir + "/gf.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --model fiber --subsample 4 --maps 8x8 --out " + dir +
                    "/fw.json");
  ASSERT_EQ(r.status, 0) << r.output;
  auto material_report = [](const std::string& f) {
    return nlohmann::json::parse(read_text_file(f))["report"];
  };
  const auto orders = material_report(dir + "/fw.json")["maps_quadrature_orders"];
  ASSERT_GT(material_report(dir + "/fw.json")["fiber_order"].get<int>(), 3) << r.output;
  ASSERT_GT(orders.value("3", 0), 0) << r.output;
  for (int i = 0; i < 2; ++i) {
    r = test::run_cli("fit " + dir + "/set --maps 8x8 --subsample 4 --global " + dir +
                      "/gf.json --tile " + std::to_string(i) + "/2 --out " + dir + "/f" +
                      std::to_string(i) + ".json");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("texel rows"), std::string::npos) << r.output;
  }
  r = test::run_cli("merge " + dir + "/f0.json " + dir + "/f1.json --out " + dir + "/fm.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(read_text_file(dir + "/f0.json").find("(the global fit's)"), std::string::npos);
  for (const char* k : {"kd", "n", "fiber", "s", "s_sigma"})
    EXPECT_TRUE(read_text_file(test::map_of(dir + "/fw", k)) ==
                read_text_file(test::map_of(dir + "/fm", k)))
        << k << ": the merged fiber-model map differs from the untiled one";
  EXPECT_EQ(material_report(dir + "/fm.json")["maps_quadrature_orders"], orders);
}

// --maps with --global in bands of texel rows (--maps-memory): each band reads only its rows of
// the views, yet the maps equal one band's byte for byte (with --smooth, whose reach each band
// fits too, and within a --tile), and the report counts every pixel once: the same pixels,
// skipped pixels (saturated ones here) and noise of the images as one band.
TEST(FitMaps, BandsOfRowsGiveOneBandsMapsAndCounts) {
  const std::string dir = test::tmp_dir("bands");
  auto r = test::run_cli("synth swirl-plate " + dir + "/set --noise 0.01 --size 64x64 --views 8");
  ASSERT_EQ(r.status, 0) << r.output;
  test::edit_json(dir + "/set/capture.json", [](auto& j) { j["color"]["saturation"] = 0.35; });
  {  // broken pixels in one view: left out as implausible, each counted once
    Image img = read_image(dir + "/set/images/003.exr").image;
    for (size_t p = 0; p < img.px.size(); p += 3 * 29) img.px[p] = -1e5f;  // not saturated
    write_exr(dir + "/set/images/003.exr", img);
    // and texture coordinates past the grid: no texel (some saturated, counted once)
    Image uv = read_image(dir + "/set/geometry/all_uv.exr").image;
    for (size_t p = 0; p < uv.px.size(); p += uv.channels * 7) uv.px[p] = 1.5f;
    write_exr(dir + "/set/geometry/all_uv.exr", uv);
  }
  r = test::run_cli("fit " + dir + "/set --subsample 2 --out " + dir + "/global.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string maps =
      " --maps 8x6 --global " + dir + "/global.json --smooth 1 " + "--smooth-sweeps 1";
  auto report = [](const std::string& f, bool tile) {
    const auto j = nlohmann::json::parse(read_text_file(f));
    return tile ? j["fit"]["report"] : j["report"];
  };
  r = test::run_cli("fit " + dir + "/set" + maps + " --out " + dir + "/one.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("bands of texel rows"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("iterations (none)"), std::string::npos) << r.output;  // no global fit
  // Without --global, records past --maps-memory: the global fit first on a --subsample that
  // fits, then the maps band by band from it, said so; the same maps, bit for bit, as those two
  // steps run by hand (`fit --subsample k`, then `fit --maps --global`).
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --maps-memory 0.01 --out " + dir +
                    "/plain.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("the global fit below ran first on 1 pixel in"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("iterations ("), std::string::npos) << r.output;  // its global fit
  EXPECT_EQ(r.output.find("held ~"), std::string::npos) << r.output;
  const auto plain = nlohmann::json::parse(read_text_file(dir + "/plain.json"));
  const int k = plain["report"].value("global_subsample", 0);
  EXPECT_GT(k, 1) << plain["report"].dump();
  EXPECT_GT(plain["report"].value("maps_bands", 0), 1) << plain["report"].dump();
  EXPECT_FALSE(plain["report"].contains("global_from")) << plain["report"].dump();
  r = test::run_cli("fit " + dir + "/set --subsample " + std::to_string(k) +
                    " --keep-anisotropic --out " + dir + "/gk.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --maps-memory 0.01 --global " + dir +
                    "/gk.json --out " + dir + "/byhand.json");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* m : {"kd", "ks", "n", "fiber", "kd_sigma", "fiber_sigma", "coverage"})
    EXPECT_TRUE(read_text_file(test::map_of(dir + "/plain", m)) ==
                read_text_file(test::map_of(dir + "/byhand", m)))
        << m << ": the maps after the subsampled global fit differ from the two steps by hand";
  const auto gk = nlohmann::json::parse(read_text_file(dir + "/gk.json"));
  for (const char* key : {"kd", "ks", "n", "fiber_angle_deg"})
    EXPECT_EQ(plain["report"]["global"][key], gk[key])
        << key << ": the global values are the subsampled fit's";
  // With a --maps-memory they fit in, the global fit takes every pixel, as before.
  r = test::run_cli("fit " + dir + "/set --maps 8x6 --out " + dir + "/whole.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("ran first on 1 pixel"), std::string::npos) << r.output;
  for (const char* mem : {"0.3", "0.01"}) {  // a few bands; one band per texel row (6)
    const std::string out = dir + "/b" + std::string(mem) + ".json";
    r = test::run_cli("fit " + dir + "/set" + maps + " --maps-memory " + mem + " --out " + out);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find(std::string(mem) == "0.3" ? "bands of texel rows" : "in 6 bands"),
              std::string::npos)
        << r.output;
    EXPECT_EQ(r.output.find("in 1 bands"), std::string::npos) << r.output;
    const std::string stem = out.substr(0, out.size() - 5);
    for (const char* k : {"kd", "ks", "n", "fiber", "kd_sigma", "ks_sigma", "n_sigma",
                          "fiber_sigma", "coverage", "determined"})
      EXPECT_TRUE(read_text_file(test::map_of(dir + "/one", k)) ==
                  read_text_file(test::map_of(stem, k)))
          << mem << " MB, " << k << ": the maps in bands differ from one band's";
    const auto a = report(dir + "/one.json", false), b = report(out, false);
    for (const char* k : {"pixels", "observations", "skipped", "warnings"})
      EXPECT_EQ(a[k], b[k]) << mem << " MB: " << k;
  }
  const auto one = report(dir + "/one.json", false);
  EXPECT_GT(one["skipped"]["saturated"].get<size_t>(), 0u) << one.dump();
  {  // --subsample without bands reads only the rows of its grid and of the noise estimate (every
     // 4th here, not all on the grid of 3): the same noise as bands at that subsample, which read
     // every row with a pixel, and the same left-out pixels, counted on the grid.
    for (const std::string& extra : {std::string(), maps + " --maps-memory 0.01"}) {
      r = test::run_cli("fit " + dir + "/set --subsample 3" + extra + " --out " + dir +
                        (extra.empty() ? "/s3.json" : "/s3b.json"));
      ASSERT_EQ(r.status, 0) << r.output;
    }
    const auto a = report(dir + "/s3.json", false), b = report(dir + "/s3b.json", false);
    EXPECT_EQ(a["pixel_noise"], b["pixel_noise"]);
    for (const char* k : {"saturated", "nonfinite"})
      EXPECT_EQ(a["skipped"][k], b["skipped"][k]) << k;
    EXPECT_GT(a["skipped"]["saturated"].get<size_t>(), 0u) << a.dump();
    EXPECT_LT(a["skipped"]["saturated"].get<size_t>() * 4,
              one["skipped"]["saturated"].get<size_t>())  // 1 pixel in 9
        << a.dump();
  }
  EXPECT_GT(one["skipped"]["implausible"].get<size_t>(), 0u) << one.dump();
  EXPECT_NE(one["warnings"].dump().find("noise of the images"), std::string::npos) << one.dump();
  // A tile in bands: the same tile, values and counts, as the tile in one band.
  r = test::run_cli("fit " + dir + "/set" + maps + " --tile 1/2 --out " + dir + "/t.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/set" + maps + " --tile 1/2 --maps-memory 0.01 --out " + dir +
                    "/tb.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto t = nlohmann::json::parse(read_text_file(dir + "/t.json")),
             tb = nlohmann::json::parse(read_text_file(dir + "/tb.json"));
  EXPECT_EQ(t["values"], tb["values"]);
  for (const char* k : {"pixels", "skipped", "maps_bands"})
    EXPECT_EQ(t["fit"]["report"][k] == tb["fit"]["report"][k], std::string(k) != "maps_bands") << k;
  EXPECT_EQ(tb["fit"]["report"]["maps_bands"], 3) << tb["fit"]["report"].dump();
  // The two tiles count every saturated or non-finite pixel once between them (those with no
  // texel: the first tile), as one untiled run does. (A pixel with no texel is no tile's record,
  // so none checks it for light or plausibility: it is outside every tile, as it always was.)
  r = test::run_cli("fit " + dir + "/set" + maps + " --tile 0/2 --maps-memory 0.01 --out " + dir +
                    "/t0.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto t0 = nlohmann::json::parse(read_text_file(dir + "/t0.json"))["fit"]["report"];
  for (const char* k : {"saturated", "nonfinite"})
    EXPECT_EQ(t0["skipped"][k].get<size_t>() + tb["fit"]["report"]["skipped"][k].get<size_t>(),
              one["skipped"][k].get<size_t>())
        << k;
  EXPECT_EQ(r.output.find("a camera per view"), std::string::npos) << r.output;
  // A view with geometry of its own (here the same buffers under other names): every band reads
  // it again, which the fit says, the bands after the first only their rows of it; the maps and
  // counts are the same, in a tile too.
  for (const char* b : {"all_P.exr", "all_N.exr", "all_U.exr", "all_uv.exr", "all_mask.png"})
    std::filesystem::copy_file(dir + "/set/geometry/" + b, dir + "/set/geometry/v1_" + b);
  test::edit_json(dir + "/set/capture.json", [](auto& j) {
    j["views"][1]["geometry"] = j["geometry"];
    for (auto& [k, v] : j["views"][1]["geometry"].items())
      v = "geometry/v1_" + v.template get<std::string>().substr(9);
  });
  r = test::run_cli("fit " + dir + "/set" + maps + " --maps-memory 0.01 --out " + dir + "/g.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("2 geometries (a camera per view): every band reads each again"),
            std::string::npos)
      << r.output;
  for (const char* k : {"kd", "ks", "n", "fiber", "kd_sigma", "ks_sigma", "n_sigma", "fiber_sigma",
                        "coverage", "determined"})
    EXPECT_TRUE(read_text_file(test::map_of(dir + "/g", k)) ==
                read_text_file(test::map_of(dir + "/b0.01", k)))
        << k << ": a view's own geometry read by rows gives other maps";
  const auto g = report(dir + "/g.json", false);
  for (const char* k : {"pixels", "observations", "skipped", "warnings"})
    EXPECT_EQ(g[k], one[k]) << k;
  {  // its pixels are counted by texel row from its mask and uv, read alone for the count
    const CaptureSet set = read_capture(dir + "/set");
    const ViewGeometry alone = load_view_uv(set, 1);
    const auto whole = load_view_geometry(set, 1);
    EXPECT_TRUE(alone.mask == whole->mask && alone.rows == whole->rows);
    EXPECT_TRUE(alone.uv.px == whole->uv.px && alone.uv.channels == 2);
    EXPECT_TRUE(alone.P.empty() && alone.N.empty() && alone.U.empty());
  }
  r = test::run_cli("fit " + dir + "/set" + maps + " --tile 1/2 --maps-memory 0.01 --out " + dir +
                    "/tg.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto tg = nlohmann::json::parse(read_text_file(dir + "/tg.json"));
  EXPECT_EQ(tg["values"], t["values"]);
  EXPECT_EQ(tg["fit"]["report"]["pixels"], t["fit"]["report"]["pixels"]);
  EXPECT_EQ(tg["fit"]["report"]["skipped"], t["fit"]["report"]["skipped"]);
  // A view whose geometry is a traced mesh has no uv to bin by (its uv buffer is not what is
  // traced): refused by name, before anything is read.
  test::edit_json(dir + "/set/capture.json", [](auto& j) {
    j["views"][1]["geometry"] = j["geometry"];  // the set's shared buffers
    j["views"][1]["geometry"]["mesh"] = "plate.obj";
  });
  r = test::run_cli("fit " + dir + "/set" + maps + " --out " + dir + "/mesh.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("views[1].geometry: --maps reads texture coordinates"), std::string::npos)
      << r.output;
}

// merge checks what it joins: tiles of two captures (each its own, or one --global across both)
// are refused, as is a --global fitted to another capture; a grid cut finer than its rows is
// refused up front with the largest N; a tile without its values, or one whose header claims a
// grid its bytes cannot hold, is named without a crash or a huge allocation.
TEST(FitMaps, MergeChecksWhatItJoins) {
  const std::string dir = test::tmp_dir("merge_checks");
  for (const char* s : {"a", "b"}) {
    auto r =
        test::run_cli(std::string("synth swirl-plate ") + dir + "/" + s +
                      " --noise 0.01 --size 32x32 --views 4 --seed " + (s[0] == 'a' ? "1" : "2"));
    ASSERT_EQ(r.status, 0) << r.output;
  }
  auto r = test::run_cli("fit " + dir + "/a --maps 4x4 --tile 0/2 --out " + dir + "/a0.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/b --maps 4x4 --tile 1/2 --out " + dir + "/b1.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("merge " + dir + "/a0.json " + dir + "/b1.json --out " + dir + "/m.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("b1.json: was fitted to another capture"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.json"));
  // Other options than tile 0's.
  r = test::run_cli("fit " + dir + "/a --maps 4x4 --tile 1/2 --subsample 2 --out " + dir +
                    "/a1s.json");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("merge " + dir + "/a0.json " + dir + "/a1s.json --out " + dir + "/m.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("other options"), std::string::npos) << r.output;
  // Tiles of two captures that share one --global (the same rig: the global fits both): merge
  // tells them apart by their files.
  r = test::run_cli("fit " + dir + "/a --out " + dir + "/ga.json");
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* t : {"a 0", "b 1"}) {
    r = test::run_cli("fit " + dir + "/" + t[0] + " --maps 4x4 --tile " + t[2] + "/2 --global " +
                      dir + "/ga.json --out " + dir + "/t" + t[0] + ".json");
    ASSERT_EQ(r.status, 0) << r.output;
  }
  r = test::run_cli("merge " + dir + "/ta.json " + dir + "/tb.json --out " + dir + "/m.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("tb.json: was fitted to another capture"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.json"));
  // A global fit of another rig's capture: refused before the work.
  r = test::run_cli("synth swirl-plate " + dir + "/c --noise 0.01 --size 32x32 --views 5");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::run_cli("fit " + dir + "/c --maps 4x4 --tile 1/2 --global " + dir + "/ga.json --out " +
                    dir + "/cg1.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("was fitted to another capture"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("iterations"), std::string::npos) << r.output;
  // N past the rows: refused with the largest N that works.
  r = test::run_cli("fit " + dir + "/a --maps 4x4 --tile 0/40 --out " + dir + "/t.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("has 4 texel rows, so at most 4 tiles"), std::string::npos) << r.output;
  // A tile without its values.
  test::edit_json(dir + "/a0.json", [](auto& j) { j.erase("values"); });
  r = test::run_cli("merge " + dir + "/a0.json --out " + dir + "/m.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("values"), std::string::npos) << r.output;
  // A 1 KB tile declaring a 16384^2 grid: named, nothing allocated for it.
  write_text_file(dir + "/forged.json",
                  R"({"format": "aniso-maps-tile", "tile": [0, 16384], "texels": [16384, 16384],
                      "rows": [0, 1], "fit": {}, "values": {}})");
  r = test::sh(test::memory_limit(2000000) + "$A merge " + dir + "/forged.json --out " + dir +
               "/m.json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("texels: declares a 16384x16384 grid"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace aniso

namespace aniso {
namespace {

// `aniso fit --maps --mpi` under `mpirun -np 2` (Open MPI on loopback): rank 0 fits the global
// parameters and hands them to every rank, rank i fits tile i/2 from them, rank 0 merges; the map
// files equal an untiled run's byte for byte. The plain binary hands over to aniso-mpi; without MPI
// the option says how to get it.
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
  // Rank 0 fitted the global parameters once; each rank kept only the pixels of its rows.
  EXPECT_NE(r.output.find("rank 0 fitted the global parameters"), std::string::npos) << r.output;
  EXPECT_EQ(nlohmann::json::parse(read_text_file(dir + "/mpi.json"))["report"]["global_from"],
            "rank 0's global fit (fit --mpi)");
  EXPECT_EQ(r.output.find(" (0 in other tiles' rows left out"), std::string::npos) << r.output;
  for (const char* k : {"kd", "ks", "n", "fiber", "fiber_sigma", "coverage", "determined"})
    EXPECT_TRUE(read_text_file(test::map_of(dir + "/whole", k)) ==
                read_text_file(test::map_of(dir + "/mpi", k)))
        << k << ": the MPI run's map differs from the untiled one";
  // A mistake is said once, by rank 0, and nothing is written.
  r = test::sh(mpirun + "\"$A\" fit " + dir + "/set --mpi --out " + dir + "/bad.json");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("give --maps"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.json"));
#endif
}

}  // namespace
}  // namespace aniso
