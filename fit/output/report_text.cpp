// The fit's console text: the summary of every value with its sigma, and the comparison against
// a ground truth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/angles.h"
#include "core/texture.h"
#include "fit/maps/maps_means.h"
#include "fit/output/report.h"
#include "io/files/files.h"
#include "io/images/image_io.h"
#include "models/material_maps.h"
#include "models/params.h"

namespace aniso {

std::string describe_fit(const FitResult& r) {
  std::ostringstream o;
  const Material& m = r.material;
  o << "  model " << model_name(m.model) << "\n";
  auto value = [&](const std::string& key) -> std::vector<double> {
    if (key == "kd") return {m.kd.begin(), m.kd.end()};
    if (key == "ks") return {m.ks.begin(), m.ks.end()};
    if (key == "n") return {m.n};
    if (key == "fiber_angle_deg") return {m.fiber_angle_deg};
    if (key == "isotropic.kd") return {m.iso_kd.begin(), m.iso_kd.end()};
    if (key == "isotropic.ks") return {m.iso_ks.begin(), m.iso_ks.end()};
    if (key == "isotropic.n") return {m.iso_n};
    if (key == "second_fiber.angle_deg") return {m.second_angle_deg};
    if (key == "second_fiber.weight") return {m.second_weight};
    if (key == "topology.s") return {m.uniform_s()};
    if (const auto* t = m.topology_as<TopologyMapRef>(); t && key == "topology.amplitude")
      return {t->amplitude};
    return {};
  };
  // The isotropic part alone (no anisotropic lobe in the data): the line lobe's numbers are 0 or
  // stand-ins, said once instead of as values.
  const bool isotropic_alone = r.report.anisotropy.isotropic_written;
  if (isotropic_alone)
    o << "  no anisotropic lobe: the isotropic part alone (k_d = k_s = 0; no n, no fiber "
         "direction)\n";
  auto line = [&](const ParamSpec& p) {
    const std::string key(p.key);
    if (isotropic_alone && (key == "kd" || key == "ks" || key == "n" || key == "fiber_angle_deg"))
      return;
    const auto s = r.sigma.find(key);
    const bool undetermined = r.undetermined.count(key) > 0;
    if (s == r.sigma.end() && !undetermined) return;  // not fitted
    const std::vector<double> v = value(key);
    char buf[160];
    for (size_t i = 0; i < v.size(); ++i) {
      const std::string name = v.size() == 3 ? key + "." + "rgb"[i] : key;
      if (undetermined || s->second.size() <= i)
        std::snprintf(buf, sizeof buf, "  %-24s %12.6g  (undetermined)\n", name.c_str(), v[i]);
      else
        std::snprintf(buf, sizeof buf, "  %-24s %12.6g +- %.3g%s\n", name.c_str(), v[i],
                      s->second[i], p.unit.empty() ? "" : (" " + std::string(p.unit)).c_str());
      o << buf;
    }
  };
  for (const auto& p : kLineParams) line(p);
  for (const auto& p : kFiberParams) line(p);
  if (r.uncertainty_basis.rfind("whole", 0) == 0) {
    // How much the views' spread added: the ratio for psi, the value a person quotes first.
    const auto w = r.sigma.find("fiber_angle_deg"), n = r.sigma_noise_only.find("fiber_angle_deg");
    o << "  +- is the " << r.uncertainty_basis;
    if (w != r.sigma.end() && n != r.sigma_noise_only.end() && n->second[0] > 0) {
      char buf[120];
      std::snprintf(buf, sizeof buf, "; the noise alone gives %.2g times less for the fiber angle",
                    w->second[0] / n->second[0]);
      o << buf;
    }
    o << "\n";
  }
  if (const auto* t = m.topology_as<TopologyMapRef>())
    o << "  topology map " << t->file << " over " << math_topology_name(t->over) << "\n";
  if (!r.s_texels.empty())
    o << "  topology: a per-texel map of s, " << r.s_texels_n << " x " << r.s_texels_n << "\n";
  if (r.maps.w > 0) {
    // The values above are the one global fit; the material's scalars are the maps' means.
    const MapsMeans mm = maps_means(r.maps);
    char buf[400];
    if (mm.texels == 0) {
      o << "  (the one global fit; no texel of the maps is determined: the material keeps these)\n";
    } else {
      std::snprintf(buf, sizeof buf,
                    "  (the one global fit, kept as report.global; the material's values are the "
                    "means of the %zu determined texels: kd %.4g %.4g %.4g, ks %.4g %.4g %.4g, n "
                    "%.4g, fiber_angle_deg %.3f%s)\n",
                    mm.texels, mm.kd[0], mm.kd[1], mm.kd[2], mm.ks[0], mm.ks[1], mm.ks[2], mm.n,
                    mm.psi_deg, mm.has_s ? (", s " + std::to_string(mm.s)).c_str() : "");
      o << buf;
    }
  }
  return o.str();
}

namespace {

// The rows of the truth table: value, sigma, shown error and error / sigma per parameter.
class TruthTable {
 public:
  explicit TruthTable(const FitResult& r) : r_(r) {
    std::snprintf(buf_, sizeof buf_, "%-18s %12s %12s %11s %11s %8s\n", "parameter", "truth", "fit",
                  "sigma", "error", "err/sig");
    o_ << buf_;
  }
  std::string text() const { return o_.str(); }

  double sig(const std::string& key, size_t i) const {
    auto it = r_.sigma.find(key);
    return it == r_.sigma.end() || i >= it->second.size() ? std::nan("") : it->second[i];
  }
  // err: shown (percent or degrees); abs_err: in the parameter's unit, compared with sigma.
  void row(const std::string& name, double t, double f, double s, double err, double abs_err,
           const char* unit, double* worst_rel, double* worst_sig, double rel) {
    const double es = std::isfinite(s) && s > 0 ? std::abs(abs_err) / s : std::nan("");
    if (std::isnan(s))
      std::snprintf(buf_, sizeof buf_, "%-18s %12.6g %12.6g %11s %10.4g%s %8s\n", name.c_str(), t,
                    f, "undetermined", err, unit, "-");
    else
      std::snprintf(buf_, sizeof buf_, "%-18s %12.6g %12.6g %11.3g %10.4g%s %8.2f\n", name.c_str(),
                    t, f, s, err, unit, es);
    o_ << buf_;
    if (worst_rel) *worst_rel = std::max(*worst_rel, rel);
    if (worst_sig && std::isfinite(es)) *worst_sig = std::max(*worst_sig, es);
  }
  // Relative error in percent; where the truth is 0, the absolute error (no percent of nothing).
  void rgb_rows(const char* key, const RGB& tv, const RGB& fv, double* worst_rel,
                double* worst_sig) {
    const char* ch = "rgb";
    for (int k = 0; k < 3; ++k) {
      const double t = tv[k], f = fv[k];
      const bool zero = std::abs(t) < 1e-12;
      const double rel = zero ? std::abs(f - t) : std::abs(f - t) / std::abs(t);
      row(std::string(key) + "." + ch[k], t, f, sig(key, k), zero ? f - t : 100 * rel, f - t,
          zero ? " abs" : "%", worst_rel, worst_sig, rel);
    }
  }
  // The fiber model's topology: the amplitude, the texels of a map of s against the true map at
  // their centres, or one s.
  void topology_rows(const Material& truth, TruthErrors* e) {
    const auto* fit_map = r_.material.topology_as<TopologyMapRef>();
    const auto* true_map = truth.topology_as<TopologyMapRef>();
    const auto* true_s_map = truth.topology_as<SMapRef>();
    if (fit_map && true_map) {
      const double d = fit_map->amplitude - true_map->amplitude;
      row("topology.amplitude", true_map->amplitude, fit_map->amplitude,
          sig("topology.amplitude", 0), d, d, "", &e->topo_abs, &e->topo_sigmas, std::abs(d));
    } else if (!r_.s_texels.empty() && true_s_map) {
      const Image t = read_image(join_path(truth.base_dir, true_s_map->file)).image;
      double worst = 0, sum2 = 0;
      const int n = r_.s_texels_n;
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const double ts = sample_first_channel(t, (x + 0.5) / n, (y + 0.5) / n);
          const double d = std::abs(r_.s_texels[static_cast<size_t>(y) * n + x] - ts);
          worst = std::max(worst, d);
          sum2 += d * d;
        }
      double smax = 0;
      for (double sd : r_.s_texel_sigma) smax = std::max(smax, sd);
      // Rows: the worst and the RMS texel error (the "truth" column is 0: these are errors).
      row("topology.s_map max", 0, worst, smax > 0 ? smax : NAN, worst, worst, "", &e->topo_abs,
          &e->topo_sigmas, worst);
      row("topology.s_map rms", 0, std::sqrt(sum2 / (n * n)), smax > 0 ? smax : NAN,
          std::sqrt(sum2 / (n * n)), 0, "", nullptr, nullptr, 0);
    } else if (r_.material.topology_as<UniformS>()) {
      const double d = r_.material.uniform_s() - truth.uniform_s();
      row("topology.s", truth.uniform_s(), r_.material.uniform_s(), sig("topology.s", 0), d, d, "",
          &e->topo_abs, &e->topo_sigmas, std::abs(d));
    }
  }

 private:
  const FitResult& r_;
  std::ostringstream o_;
  char buf_[200];
};

}  // namespace

std::string compare_to_truth(const FitResult& r, const Material& truth, TruthErrors* errors) {
  TruthTable tt(r);
  TruthErrors e;
  tt.rgb_rows("kd", truth.kd, r.material.kd, &e.kd_rel, &e.kd_sigmas);
  tt.rgb_rows("ks", truth.ks, r.material.ks, &e.ks_rel, &e.ks_sigmas);
  const double rel = std::abs(r.material.n - truth.n) / truth.n;
  tt.row("n", truth.n, r.material.n, tt.sig("n", 0), 100 * rel, r.material.n - truth.n, "%",
         &e.n_rel, &e.n_sigmas, rel);
  const double d = fiber_deg_distance(r.material.fiber_angle_deg, truth.fiber_angle_deg);
  tt.row("fiber_angle_deg", truth.fiber_angle_deg, r.material.fiber_angle_deg,
         tt.sig("fiber_angle_deg", 0), d, d, " deg", &e.psi_deg, &e.psi_sigmas, d);
  if (r.material.fiber() && truth.fiber()) tt.topology_rows(truth, &e);
  if (r.material.has_second_fiber && truth.has_second_fiber) {
    const double d2 = fiber_deg_distance(r.material.second_angle_deg, truth.second_angle_deg);
    tt.row("second.angle_deg", truth.second_angle_deg, r.material.second_angle_deg,
           tt.sig("second_fiber.angle_deg", 0), d2, d2, " deg", nullptr, nullptr, 0);
    const double dw = r.material.second_weight - truth.second_weight;
    tt.row("second.weight", truth.second_weight, r.material.second_weight,
           tt.sig("second_fiber.weight", 0), dw, dw, "", nullptr, nullptr, 0);
  }
  if (errors) *errors = e;
  return tt.text();
}

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

std::string compare_maps_to_truth(const FitResult& r, const Material& truth) {
  const TexelMaps& m = r.maps;
  struct Column {
    std::string name;
    const char* unit;
    std::vector<double> err, z;  // |error| (percent or degrees), |error| / sigma
  };
  std::vector<Column> cols;
  for (const char* key : {"kd", "ks"})
    for (int c = 0; c < 3; ++c) cols.push_back({std::string(key) + "." + "rgb"[c], "%", {}, {}});
  cols.push_back({"n", "%", {}, {}});
  cols.push_back({"fiber_angle_deg", "deg", {}, {}});
  size_t determined = 0;
  for (int row = m.row0; row < m.row1; ++row)
    for (int col = 0; col < m.w; ++col) {
      const size_t t = static_cast<size_t>(row - m.row0) * m.w + col;
      if (!m.determined[t]) continue;
      ++determined;
      const Material at = material_at(truth, (col + 0.5) / m.w, (row + 0.5) / m.h);
      auto put = [&](Column& c, double fit, double tv, double sigma, bool relative) {
        const double d = std::abs(fit - tv);
        c.err.push_back(relative && std::abs(tv) > 1e-12 ? 100 * d / std::abs(tv) : d);
        if (sigma > 0 && std::isfinite(sigma)) c.z.push_back(d / sigma);
      };
      for (int c = 0; c < 3; ++c) {
        put(cols[c], m.kd[3 * t + c], at.kd[c], m.kd_sigma[3 * t + c], true);
        put(cols[3 + c], m.ks[3 * t + c], at.ks[c], m.ks_sigma[3 * t + c], true);
      }
      put(cols[6], m.n[t], at.n, m.n_sigma[t], true);
      const double d = fiber_deg_distance(m.psi_deg[t], at.fiber_angle_deg);
      cols[7].err.push_back(d);
      if (m.psi_sigma_deg[t] > 0) cols[7].z.push_back(d / m.psi_sigma_deg[t]);
    }
  if (determined == 0) return "no texel is determined: none to compare\n";
  std::ostringstream o;
  char buf[200];
  std::snprintf(buf, sizeof buf, "at the centres of the %zu determined texels of %dx%d%s:\n",
                determined, m.w, m.row1 - m.row0,
                truth.maps.any() ? "" : " (the truth has no maps: one value for every texel)");
  o << buf;
  std::snprintf(buf, sizeof buf, "%-18s %14s %14s %15s\n", "parameter", "median |error|",
                "90% |error|", "median err/sig");
  o << buf;
  for (const Column& c : cols) {
    const double med = percentile(c.err, 0.5), p90 = percentile(c.err, 0.9),
                 z = percentile(c.z, 0.5);
    std::snprintf(buf, sizeof buf, "%-18s %10.3g %-3s %10.3g %-3s %15.2f\n", c.name.c_str(), med,
                  c.unit, p90, c.unit, z);
    o << buf;
  }
  return o.str();
}

}  // namespace aniso
