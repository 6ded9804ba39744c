// RGL material-database files (.bsdf, io/formats/rgl_bsdf.h): the database's own reader's values on
// the two shared files, hostile files refused by field, and a round trip through an anisotropic
// file this test writes in the format.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/formats/rgl_bsdf.h"
#include "io/formats/table.h"
#include "models/evaluate.h"
#include "test_util.h"

namespace aniso {
namespace {

// The two database files the repository carries (tests/data/rgl/README.md).
const std::string kData = std::string(ANISO_SOURCE_DIR) + "/tests/data/rgl/";

// The reference values of the database's reader (powitacq eval(wi = V, wo = L)), from the data's
// README: theta_L, phi_L, theta_V, phi_V, R, G, B.
struct Reference {
  const char* file;
  double tl, pl, tv, pv, rgb[3];
};
constexpr Reference kReference[] = {
    {"paper_white", 0, 0, 54.7356103, 45, {0.260544926, 0.2642726, 0.308619231}},
    {"paper_white", 30, 0, 30, 180, {0.244924083, 0.248000771, 0.287851691}},
    {"paper_white", 45, 0, 45, 180, {0.21188657, 0.213187948, 0.242898747}},
    {"paper_white", 30, 0, 45, 120, {0.234909281, 0.237836644, 0.27569893}},
    {"paper_white", 60, 90, 20, 300, {0.136227638, 0.138100132, 0.16031453}},
    {"paper_white", 10, 0, 70, 180, {0.251580864, 0.254741609, 0.295441866}},
    {"satin_rosaline", 0, 0, 54.7356103, 45, {0.169741288, 0.216606662, 0.200563982}},
    {"satin_rosaline", 30, 0, 30, 180, {2.51620293, 1.51298702, 1.8765682}},
    {"satin_rosaline", 45, 0, 45, 180, {3.01057005, 2.13265705, 2.24956822}},
    {"satin_rosaline", 30, 0, 45, 120, {0.154214919, 0.191337422, 0.181167662}},
    {"satin_rosaline", 60, 90, 20, 300, {0.0915985778, 0.109232612, 0.103331365}},
    {"satin_rosaline", 10, 0, 70, 180, {0.161596388, 0.194598004, 0.182850152}},
};

TEST(RglBsdf, EveryReferenceValueOfTheDatabasesReaderWithinATenthOfAPercent) {
  double worst = 0;
  for (const Reference& r : kReference) {
    const RglBsdf b = RglBsdf::read(kData + r.file + "_rgb.bsdf");
    EXPECT_TRUE(b.isotropic());
    const auto f = b.eval(dir_from_angles(r.tl, r.pl), dir_from_angles(r.tv, r.pv));
    for (int c = 0; c < 3; ++c) {
      const double rel = std::abs(f[c] / r.rgb[c] - 1);
      worst = std::max(worst, rel);
      EXPECT_LT(rel, 1e-3) << r.file << " row " << r.tl << " " << r.pl << " " << r.tv << " " << r.pv
                           << " channel " << c << ": " << f[c] << " against " << r.rgb[c];
    }
  }
  std::printf("RGL reader against powitacq on 12 rows x 3 channels: worst relative %.2e\n", worst);
  // The light and view are not interchangeable: the data are not reciprocal to the last digit.
  const RglBsdf satin = RglBsdf::read(kData + "satin_rosaline_rgb.bsdf");
  const auto a = satin.eval(dir_from_angles(30, 0), dir_from_angles(45, 120));
  const auto b = satin.eval(dir_from_angles(45, 120), dir_from_angles(30, 0));
  EXPECT_GT(std::abs(a[1] / std::cos(M_PI / 6) / (b[1] / std::cos(M_PI / 4)) - 1), 1e-4);
}

// A tensor file as the database writes it (little-endian): "tensor_file\0", version 1.0, fields.
struct TensorField {
  std::string name;
  uint8_t dtype;  // 1 uint8, 10 float32
  std::vector<uint64_t> shape;
  std::string data;
};
std::string tensor_bytes(const std::vector<TensorField>& fields) {
  std::string head("tensor_file\0", 12);
  head += std::string("\x01\x00", 2);
  auto put = [&](auto v) { head.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(static_cast<uint32_t>(fields.size()));
  size_t header = head.size();
  for (const auto& f : fields) header += 2 + f.name.size() + 2 + 1 + 8 + 8 * f.shape.size();
  uint64_t offset = header;
  std::string body;
  for (const auto& f : fields) {
    put(static_cast<uint16_t>(f.name.size()));
    head += f.name;
    put(static_cast<uint16_t>(f.shape.size()));
    put(f.dtype);
    put(offset);
    for (uint64_t s : f.shape) put(s);
    body += f.data;
    offset += f.data.size();
  }
  return head + body;
}
// The light that mirrors viewer V about the half vector at (u, v) of the NDF's grid coordinates
// (theta_h = u^2 pi / 2, phi_h = (2 v - 1) pi).
LocalDir mirrored_light(const LocalDir& V, double u, double v) {
  const double th = u * u * M_PI / 2, ph = (2 * v - 1) * M_PI;
  const double hx = std::sin(th) * std::cos(ph), hy = std::sin(th) * std::sin(ph),
               hz = std::cos(th);
  const double d = V.u * hx + V.w * hy + V.n * hz;
  return {2 * d * hx - V.u, 2 * d * hy - V.w, 2 * d * hz - V.n};
}

std::string float_bytes(const std::vector<float>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * 4);
}

// An anisotropic file of a material: the viewer on a (phi_i, theta_i) grid, NDF, VNDF and sigma
// constant (so the inverse warp is the identity and ndf / 4 sigma is 1), and rgb holding
// f_r cos(theta_L) at the grid's half vectors, the light the viewer's mirror about each. With
// `nm`, a spectral file instead: "spectra" at those wavelengths, the material's red channel times
// spectrum(nm).
std::vector<TensorField> file_of(const Material& m, int nphi, int ntheta, int n,
                                 const std::vector<float>& nm = {},
                                 const std::function<double(double)>& spectrum = {}) {
  const size_t channels = nm.empty() ? 3 : nm.size();
  const Evaluator ev(m);
  std::vector<float> phi(nphi), theta(ntheta);
  for (int i = 0; i < nphi; ++i) phi[i] = static_cast<float>(-M_PI + 2 * M_PI * i / (nphi - 1));
  for (int i = 0; i < ntheta; ++i)
    theta[i] = static_cast<float>(80.0 * M_PI / 180 * i / (ntheta - 1));
  std::vector<float> rgb(static_cast<size_t>(nphi) * ntheta * channels * n * n), ones(n * n, 1.f),
      quarter(n * n, 0.25f), vndf(static_cast<size_t>(nphi) * ntheta * n * n, 1.f);
  for (int p = 0; p < nphi; ++p)
    for (int t = 0; t < ntheta; ++t) {
      const LocalDir V{std::sin(theta[t]) * std::cos(phi[p]), std::sin(theta[t]) * std::sin(phi[p]),
                       std::cos(theta[t])};
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const LocalDir L = mirrored_light(V, double(x) / (n - 1), double(y) / (n - 1));
          double f[3] = {0, 0, 0};
          if (L.n > 0) ev(L, V, f);
          for (size_t c = 0; c < channels; ++c)
            rgb[((static_cast<size_t>(p) * ntheta + t) * channels + c) * n * n + y * n + x] =
                static_cast<float>(nm.empty() ? f[c] : f[0] * spectrum(nm[c]));
        }
    }
  const std::vector<uint64_t> grid{uint64_t(n), uint64_t(n)};
  std::vector<TensorField> values{{"rgb",
                                   10,
                                   {uint64_t(nphi), uint64_t(ntheta), 3, uint64_t(n), uint64_t(n)},
                                   float_bytes(rgb)}};
  if (!nm.empty())
    values = {{"wavelengths", 10, {uint64_t(nm.size())}, float_bytes(nm)},
              {"spectra",
               10,
               {uint64_t(nphi), uint64_t(ntheta), uint64_t(nm.size()), uint64_t(n), uint64_t(n)},
               float_bytes(rgb)}};
  std::vector<TensorField> fields{
      {"description", 1, {4}, "test"},
      {"jacobian", 1, {1}, std::string("\x01", 1)},
      {"theta_i", 10, {uint64_t(ntheta)}, float_bytes(theta)},
      {"phi_i", 10, {uint64_t(nphi)}, float_bytes(phi)},
      {"ndf", 10, grid, float_bytes(ones)},
      {"sigma", 10, grid, float_bytes(quarter)},
      {"vndf", 10, {uint64_t(nphi), uint64_t(ntheta), uint64_t(n), uint64_t(n)}, float_bytes(vndf)},
      {"luminance",
       10,
       {uint64_t(nphi), uint64_t(ntheta), uint64_t(n), uint64_t(n)},
       float_bytes(vndf)}};
  fields.insert(fields.end(), values.begin(), values.end());
  return fields;
}

Material brushed_line() {
  Material m;
  m.kd = {0.2, 0.15, 0.1};
  m.ks = {0.6, 0.6, 0.6};
  m.n = 20;
  m.fiber_angle_deg = 30;
  return m;
}

// An anisotropic file written from a line-model material reads back as that material at its
// grid's nodes (float rounding) and near it between them; `aniso fit` on it recovers psi and n.
TEST(RglBsdf, AnAnisotropicFileRoundTripsAndFitsBackToItsMaterial) {
  const Material m = brushed_line();
  const int nphi = 25, ntheta = 9, n = 33;
  const std::string dir = test::tmp_dir("rgl_roundtrip");
  const std::string path = dir + "/brushed.bsdf";
  write_text_file(path, tensor_bytes(file_of(m, nphi, ntheta, n)));
  const RglBsdf b = RglBsdf::read(path);
  EXPECT_FALSE(b.isotropic());
  const Evaluator ev(m);
  double at_nodes = 0, between = 0, peak = 0;
  for (int p = 0; p < nphi; p += 3)
    for (int t = 1; t < ntheta; t += 2) {
      const double phi = b.phi_i()[p], theta = b.theta_i()[t];
      const LocalDir V{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                       std::cos(theta)};
      for (int k = 0; k < 40; ++k) {
        // Half vectors on the grid's nodes (even k) and between them (odd k).
        const double u = (k % 2 == 0 ? (k / 2) % 8 * 4.0 : (k / 2) % 8 * 4.0 + 1.5) / (n - 1);
        const double v = (k % 2 == 0 ? (k * 7) % 32 : (k * 7) % 32 + 0.5) / (n - 1);
        const LocalDir L = mirrored_light(V, u, v);
        if (L.n < 0.1) continue;
        double f[3];
        ev(L, V, f);
        const auto g = b.eval(L, V);
        peak = std::max(peak, f[0]);
        double& worst = k % 2 == 0 ? at_nodes : between;
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(g[c] - f[c]));
      }
    }
  std::printf("round trip: at the nodes within %.2e, between them %.2e (peak %.3f)\n", at_nodes,
              between, peak);
  EXPECT_LT(at_nodes, 2e-5 * peak);
  EXPECT_LT(between, 0.05 * peak);
  auto r = test::run_cli("fit " + path + " --out " + dir + "/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("anisotropic"), std::string::npos) << r.output;
  const auto j = nlohmann::json::parse(read_text_file(dir + "/m.json"));
  std::printf("fit of the file: psi %.3f, n %.2f, k_d.r %.4f, relative RMS %.4f\n",
              j["fiber_angle_deg"].get<double>(), j["n"].get<double>(), j["kd"][0].get<double>(),
              j["report"]["measured"]["relative_rms"].get<double>());
  EXPECT_NEAR(j["fiber_angle_deg"].get<double>(), 30, 1.0);
  EXPECT_NEAR(j["n"].get<double>() / 20, 1, 0.1);
  EXPECT_LT(j["report"]["measured"]["relative_rms"].get<double>(), 0.05);
  const auto& test = j["report"]["anisotropy_test"];
  std::printf("anisotropy test: BIC %.1f anisotropic, %.1f isotropic\n",
              test["bic_anisotropic"].get<double>(), test["bic_isotropic"].get<double>());
  EXPECT_EQ(test["preferred"], "anisotropic");
  EXPECT_GT(test["bic_isotropic"].get<double>() - test["bic_anisotropic"].get<double>(), 100.0);
  // aniso report: the file's lobe against the fitted one, in the fiber's frame.
  r = test::run_cli("report " + dir + "/m.json --capture " + path + " --out " + dir + "/rep");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string lobe = read_text_file(dir + "/rep/lobe.svg");
  double worst = 0;
  int panels = 0;
  for (size_t at = lobe.find("data-misfit='"); at != std::string::npos;
       at = lobe.find("data-misfit='", at + 1), ++panels)
    worst = std::max(worst, std::stod(lobe.substr(at + 13)));
  std::printf("report of the file: %d lobe panels, worst misfit %.4f of the lobe's peak\n", panels,
              worst);
  EXPECT_GE(panels, 2);
  EXPECT_LT(worst, 0.05);
  EXPECT_FALSE(std::filesystem::exists(dir + "/rep/residual_histogram.svg"));  // no images' noise
  EXPECT_NE(read_text_file(dir + "/rep/index.html").find("the data show an anisotropic lobe"),
            std::string::npos);
  // eval: the file's values into a table.
  write_text_file(dir + "/dirs.csv", "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg\n30,0,30,180\n");
  r = test::run_cli("eval " + path + " --table " + dir + "/dirs.csv --out " + dir + "/v.csv");
  ASSERT_EQ(r.status, 0) << r.output;
  const SampleTable t = read_table(dir + "/v.csv");
  const auto g = b.eval(dir_from_angles(30, 0), dir_from_angles(30, 180));
  EXPECT_NEAR(t.rows.at(0).value[1], g[1], 1e-6 * g[1]);
}

// An isotropic measured file does not come back with a fiber direction.
TEST(RglBsdf, AnIsotropicFileGetsNoFiberDirection) {
  const std::string dir = test::tmp_dir("rgl_iso");
  auto r = test::run_cli("fit " + kData + "paper_white_rgb.bsdf --out " + dir + "/p.json");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(read_text_file(dir + "/p.json"));
  EXPECT_TRUE(j["uncertainty"]["fiber_angle_deg"].is_null()) << j["uncertainty"].dump();
  EXPECT_NE(j["undetermined"]["fiber_angle_deg"].get<std::string>().find("isotropic"),
            std::string::npos);
  EXPECT_GE(j["report"]["measured"]["by_view_angle"].size(), 5u);
}

// A file on an anisotropic grid of a material without anisotropy (Lambert + Blinn-Phong): the
// line model's fit would report a fiber direction with a sigma; the isotropic part alone wins by
// BIC and is what is written, without one. --keep-anisotropic keeps the line fit, its direction
// undetermined.
TEST(RglBsdf, AnIsotropicMaterialOnAnAnisotropicGridGetsNoFiberDirection) {
  Material m;
  m.kd = {0, 0, 0};
  m.ks = {0, 0, 0};
  m.has_isotropic = true;
  m.iso_kd = {0.25, 0.2, 0.15};
  m.iso_ks = {0.5, 0.5, 0.5};
  m.iso_n = 30;
  const std::string dir = test::tmp_dir("rgl_iso_grid");
  const std::string path = dir + "/plastic.bsdf";
  write_text_file(path, tensor_bytes(file_of(m, 25, 9, 33)));
  EXPECT_FALSE(RglBsdf::read(path).isotropic());
  auto r = test::run_cli("fit " + path + " --out " + dir + "/m.json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("no anisotropic lobe"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("fiber_angle_deg  "), std::string::npos) << r.output;  // not as a value
  auto j = nlohmann::json::parse(read_text_file(dir + "/m.json"));
  const auto& test = j["report"]["anisotropy_test"];
  std::printf(
      "isotropic material: BIC %.1f anisotropic, %.1f isotropic; k_d,iso %.4f, k_s,iso "
      "%.4f, n_iso %.2f, relative RMS %.2e\n",
      test["bic_anisotropic"].get<double>(), test["bic_isotropic"].get<double>(),
      j["isotropic"]["kd"][0].get<double>(), j["isotropic"]["ks"][0].get<double>(),
      j["isotropic"]["n"].get<double>(), j["report"]["measured"]["relative_rms"].get<double>());
  EXPECT_EQ(test["preferred"], "isotropic");
  EXPECT_EQ(test["written"], "isotropic");
  EXPECT_TRUE(j["uncertainty"]["fiber_angle_deg"].is_null()) << j["uncertainty"].dump();
  EXPECT_NE(j["undetermined"]["fiber_angle_deg"].get<std::string>().find("no anisotropic lobe"),
            std::string::npos);
  EXPECT_NEAR(j["isotropic"]["kd"][0].get<double>(), 0.25, 0.0025);
  EXPECT_NEAR(j["isotropic"]["ks"][1].get<double>(), 0.5, 0.005);
  EXPECT_NEAR(j["isotropic"]["n"].get<double>(), 30, 0.3);
  EXPECT_LT(j["report"]["measured"]["relative_rms"].get<double>(), 0.01);
  EXPECT_TRUE(j["uncertainty"]["isotropic"].is_object()) << j["uncertainty"].dump();
  // It exports like any material, its glTF lobe from its Blinn-Phong lobe: hardly anisotropic.
  r = test::run_cli("export " + dir + "/m.json --out " + dir + "/exp");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto ex = nlohmann::json::parse(read_text_file(dir + "/exp/export.json"));
  std::printf("its glTF: roughness %.3f, anisotropy strength %.3f\n",
              ex["gltf"]["roughness"].get<double>(),
              ex["gltf"]["anisotropy_strength"].get<double>());
  EXPECT_LT(ex["gltf"]["anisotropy_strength"].get<double>(), 0.2);

  r = test::run_cli("fit " + path + " --keep-anisotropic --out " + dir + "/k.json");
  ASSERT_EQ(r.status, 0) << r.output;
  j = nlohmann::json::parse(read_text_file(dir + "/k.json"));
  EXPECT_EQ(j["report"]["anisotropy_test"]["written"], "anisotropic");
  EXPECT_TRUE(j["uncertainty"]["fiber_angle_deg"].is_null()) << j["uncertainty"].dump();
  EXPECT_NE(j["undetermined"]["fiber_angle_deg"].get<std::string>().find("--keep-anisotropic"),
            std::string::npos);
  EXPECT_GT(j["kd"][0].get<double>() + j["ks"][0].get<double>(), 0.1);
}

// A spectral file (the database's NAME_spectral.bsdf): its values at each wavelength are the
// written ones (float rounding at the grid's nodes), a flat spectrum is grey in RGB, one of long
// wavelengths alone is red, and it fits like an RGB file.
TEST(RglBsdf, ASpectralFileReadsItsSpectraAndFitsInRgb) {
  Material m = brushed_line();
  m.kd = {0.2, 0.2, 0.2};
  std::vector<float> nm;
  for (float l = 360; l <= 830; l += 10) nm.push_back(l);
  const std::string dir = test::tmp_dir("rgl_spectral");
  const std::string flat = dir + "/flat.bsdf", red = dir + "/red.bsdf";
  write_text_file(flat, tensor_bytes(file_of(m, 25, 9, 33, nm, [](double) { return 1.0; })));
  write_text_file(
      red, tensor_bytes(file_of(m, 25, 9, 33, nm, [](double l) { return l >= 600 ? 1.0 : 0.0; })));
  const RglBsdf b = RglBsdf::read(flat), r = RglBsdf::read(red);
  ASSERT_TRUE(b.spectral());
  EXPECT_EQ(b.wavelengths(), nm);
  const Evaluator ev(m);
  double worst_spectrum = 0, worst_grey = 0, peak = 0;
  std::array<float, 3> reddest{0, 0, 0};
  for (int p = 0; p < 25; p += 4)
    for (int t = 1; t < 9; t += 3) {
      const double phi = b.phi_i()[p], theta = b.theta_i()[t];
      const LocalDir V{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                       std::cos(theta)};
      for (int k = 0; k < 16; ++k) {  // half vectors on the grid's nodes
        const LocalDir L = mirrored_light(V, (k % 8) * 4.0 / 32, ((k * 7) % 32) / 32.0);
        if (L.n < 0.1) continue;
        double f[3];
        ev(L, V, f);
        peak = std::max(peak, f[0]);
        for (float s : b.eval_spectrum(L, V))
          worst_spectrum = std::max(worst_spectrum, std::abs(s - f[0]));
        for (float g : b.eval(L, V)) worst_grey = std::max(worst_grey, std::abs(g - f[0]));
        const auto c = r.eval(L, V);
        if (c[0] > reddest[0]) reddest = c;
      }
    }
  std::printf(
      "spectral file: spectra within %.2e of the written values, a flat spectrum's RGB "
      "within %.2e of grey (peak %.3f); long wavelengths alone give RGB %.4f %.4f %.4f\n",
      worst_spectrum, worst_grey, peak, reddest[0], reddest[1], reddest[2]);
  EXPECT_LT(worst_spectrum, 2e-5 * peak);
  EXPECT_LT(worst_grey, 1e-4 * peak);
  EXPECT_GT(reddest[0], 5 * reddest[1]);
  EXPECT_GT(reddest[0], 5 * reddest[2]);
  EXPECT_TRUE(RglBsdf::read(kData + "paper_white_rgb.bsdf")
                  .eval_spectrum(dir_from_angles(30, 0), dir_from_angles(30, 180))
                  .empty());

  auto res = test::run_cli("fit " + flat + " --out " + dir + "/m.json");
  ASSERT_EQ(res.status, 0) << res.output;
  const auto j = nlohmann::json::parse(read_text_file(dir + "/m.json"));
  std::printf("fit of the spectral file: psi %.3f, n %.2f, k_d %.4f %.4f %.4f\n",
              j["fiber_angle_deg"].get<double>(), j["n"].get<double>(), j["kd"][0].get<double>(),
              j["kd"][1].get<double>(), j["kd"][2].get<double>());
  EXPECT_NEAR(j["fiber_angle_deg"].get<double>(), 30, 1.0);
  EXPECT_NEAR(j["n"].get<double>() / 20, 1, 0.1);
  EXPECT_NEAR(j["kd"][1].get<double>(), 0.2, 0.01);

  // A spectral file whose wavelengths miss the visible range, or whose spectra disagree with them.
  auto ir = file_of(m, 5, 3, 4, {1200.f, 1300.f}, [](double) { return 1.0; });
  write_text_file(dir + "/ir.bsdf", tensor_bytes(ir));
  try {
    RglBsdf::read(dir + "/ir.bsdf");
    ADD_FAILURE() << "an infrared file was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("wavelengths"), std::string::npos) << e.what();
  }
  auto wrong = file_of(m, 5, 3, 4, {500.f, 600.f}, [](double) { return 1.0; });
  wrong.back().shape[2] = 1;
  write_text_file(dir + "/wrong.bsdf", tensor_bytes(wrong));
  try {
    RglBsdf::read(dir + "/wrong.bsdf");
    ADD_FAILURE() << "spectra of the wrong shape were read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("spectra"), std::string::npos) << e.what();
  }
}

// Hostile files: each refused naming what is wrong, before anything is allocated past the file.
TEST(RglBsdf, HostileFilesAreRefusedByField) {
  const std::string dir = test::tmp_dir("rgl_hostile");
  const std::string good = tensor_bytes(file_of(brushed_line(), 5, 3, 4));
  auto refused = [&](const std::string& bytes, const std::string& what) {
    write_text_file(dir + "/x.bsdf", bytes);
    try {
      RglBsdf::read(dir + "/x.bsdf");
      ADD_FAILURE() << "accepted; expected: " << what;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  refused(good.substr(0, good.size() / 2), "truncated");
  refused(good.substr(0, good.size() - 4), "run past the end of the file");
  refused(good.substr(0, 10), "too small");
  refused("tensor_filX" + good.substr(11), "not \"tensor_file\"");
  {  // a shape of 2^40 values
    std::vector<TensorField> f = file_of(brushed_line(), 5, 3, 4);
    f[8].shape[0] = uint64_t{1} << 40;
    refused(tensor_bytes(f), "more bytes than the whole file");
  }
  {  // NaN in sigma
    std::vector<TensorField> f = file_of(brushed_line(), 5, 3, 4);
    const float nan = NAN;
    std::memcpy(f[5].data.data() + 8, &nan, 4);
    refused(tensor_bytes(f), "field \"sigma\" holds a value that is not finite");
  }
  {  // rgb of the wrong shape
    std::vector<TensorField> f = file_of(brushed_line(), 5, 3, 4);
    f[8].shape[2] = 2;
    refused(tensor_bytes(f), "rgb's shape");
  }
  {  // a missing field
    std::vector<TensorField> f = file_of(brushed_line(), 5, 3, 4);
    f.erase(f.begin() + 4);
    refused(tensor_bytes(f), "field \"ndf\" is missing");
  }
}

}  // namespace
}  // namespace aniso
