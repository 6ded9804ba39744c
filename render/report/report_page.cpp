#include "render/report/report_page.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "io/formats/rgl_bsdf.h"
#include "io/formats/table.h"
#include "io/images/image_io.h"
#include "models/material_maps.h"
#include "render/preview/verify.h"
#include "render/report/report_figures.h"

namespace aniso {

namespace {

using json = nlohmann::json;

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<')
      o += "&lt;";
    else if (c == '>')
      o += "&gt;";
    else if (c == '&')
      o += "&amp;";
    else if (c == '"')
      o += "&quot;";
    else
      o += c;
  }
  return o;
}

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

// A value or an array of them, as text.
std::string values(const json& v) {
  if (v.is_number()) return num(v.get<double>());
  if (v.is_array()) {
    std::string s;
    for (const auto& x : v)
      s += (s.empty() ? "" : " ") + (x.is_number() ? num(x.get<double>()) : "?");
    return s;
  }
  if (v.is_null()) return "undetermined";
  return esc(v.dump());
}

// The correlation matrix as an SVG heat map: blue -1, white 0, red +1, each cell's value written.
std::string correlation_svg(const json& c) {
  const auto& names = c["parameters"];
  const auto& m = c["matrix"];
  const int n = static_cast<int>(names.size()), cell = 44, left = 110, top = 110;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << left + n * cell + 10 << "' height='"
    << top + n * cell + 10 << "' font-family='sans-serif' font-size='10'>\n";
  for (int i = 0; i < n; ++i) {
    const std::string name = esc(names[i].get<std::string>());
    s << "<text x='" << left - 4 << "' y='" << top + i * cell + cell / 2 + 3
      << "' text-anchor='end'>" << name << "</text>\n";
    s << "<text transform='translate(" << left + i * cell + cell / 2 + 3 << "," << top - 4
      << ") rotate(-60)'>" << name << "</text>\n";
    for (int k = 0; k < n; ++k) {
      const double v = m[i][k].is_number() ? m[i][k].get<double>() : 0;
      const double a = std::min(1.0, std::abs(v));
      const int r = v >= 0 ? 255 : static_cast<int>(255 * (1 - a));
      const int b = v <= 0 ? 255 : static_cast<int>(255 * (1 - a));
      const int g = static_cast<int>(255 * (1 - a));
      char val[16];
      std::snprintf(val, sizeof val, "%.2f", v);
      s << "<rect x='" << left + k * cell << "' y='" << top + i * cell << "' width='" << cell
        << "' height='" << cell << "' fill='rgb(" << r << "," << g << "," << b
        << ")' stroke='#ccc'/><text class='corr' x='" << left + k * cell + cell / 2 << "' y='"
        << top + i * cell + cell / 2 + 3 << "' text-anchor='middle' data-value='" << num(v) << "'>"
        << val << "</text>\n";
    }
  }
  s << "</svg>\n";
  return s.str();
}

// The maps beyond their previews: the fiber direction as a field of glyphs, and the sigma and
// coverage maps as pictures with their ranges.
void map_figures(const json& j, const std::string& base, const std::string& dir,
                 std::ostringstream* h, ReportSummary* sum) {
  auto file = [&](const char* block, const char* key) -> std::string {
    if (!j.contains(block) || !j[block].is_object() || !j[block].contains(key) ||
        !j[block][key].is_string())
      return "";
    const std::string f = join_path(base, j[block][key].get<std::string>());
    std::error_code ec;
    return std::filesystem::is_regular_file(f, ec) ? f : "";
  };
  std::filesystem::create_directories(join_path(dir, "maps"));
  if (const std::string f = file("maps", "fiber"); !f.empty()) {
    const Image fiber = read_image(f).image;
    Image det;
    if (const std::string d = file("maps_uncertainty", "determined"); !d.empty())
      det = read_image(d).image;
    if (fiber.channels >= 2) {
      std::ofstream(join_path(dir, "maps/direction_field.svg"))
          << direction_field_svg(fiber, det.px.empty() ? nullptr : &det);
      *h << "<h3>Fiber direction</h3>\n<figure style='max-width:none'><img "
            "src='maps/direction_field.svg'><figcaption>"
            "the fiber's direction per texel (u to the right, v down, as the map's rows run); "
            "pale where the data do not determine it</figcaption></figure>\n";
      sum->direction_field = true;
    }
  }
  struct Pic {
    const char *key, *what;
    bool log;
  };
  const Pic pics[] = {{"fiber", "sigma of the fiber angle (degrees)", true},
                      {"n", "sigma of n", true},
                      {"kd", "sigma of k_d (red)", true},
                      {"coverage", "pixels per texel", true},
                      {"residual", "RMS residual per texel (image units)", true}};
  bool any = false;
  for (const Pic& p : pics) {
    const std::string f = file("maps_uncertainty", p.key);
    if (f.empty()) continue;
    if (!any) *h << "<h3>How sure, texel by texel</h3>\n", any = true;
    double lo = 0, hi = 0;
    const Image pic = scalar_map_picture(read_image(f).image, p.log, &lo, &hi);
    const std::string name = std::string("maps/uncertainty_") + p.key + ".png";
    write_png(join_path(dir, name), pic, 8);
    *h << "<figure><img src='" << name << "' width='256'><figcaption>" << p.what << ": " << num(lo)
       << " (dark blue) to " << num(hi) << " (yellow)" << (p.log ? ", log scale" : "")
       << "; grey: not known</figcaption></figure>\n";
    ++sum->maps;
  }
}

// A sample table's readings (a .csv, or a measured .bsdf on its own grid) as lobe samples, every
// k-th row up to the samples' limit: the reading less the material's diffuse part, and the
// model's specular part at the same directions.
VerifySamples table_samples(const std::string& path, const Material& m) {
  const SampleTable t = is_rgl_bsdf(path) ? measured_table(RglBsdf::read(path)) : read_table(path);
  VerifySamples s;
  const size_t stride = std::max<size_t>(1, (t.rows.size() + s.max_lobe - 1) / s.max_lobe);
  for (size_t i = 0; i < t.rows.size(); i += stride) {
    const SampleRow& r = t.rows[i];
    const LocalDir L = dir_from_angles(r.theta_i, r.phi_i), V = dir_from_angles(r.theta_o, r.phi_o);
    const Material at = t.has_uv && m.maps.any() ? material_at(m, r.u, r.v) : m;
    double f, fd;
    VerifySamples::reflectance_and_diffuse(at, L, V, t.has_s ? r.s : m.uniform_s(), &f, &fd);
    const VerifySamples::Lobe l =
        VerifySamples::lobe_at(L, V, at.fiber_angle_deg, r.value[1] - fd, f - fd);
    if (std::isfinite(l.data) && std::isfinite(l.model)) s.lobe.push_back(l);
  }
  return s;
}

// The capture against the model beyond the views' table: the residuals against the unit
// Gaussian, the lobe against the data in the fiber's frame, and the half vectors the capture saw.
void capture_figures(const VerifySamples& s, const std::string& dir, std::ostringstream* h) {
  size_t residuals = s.below + s.above;
  for (size_t c : s.histogram) residuals += c;
  if (residuals > 0) {  // (a sample table has no images' noise)
    std::ofstream(join_path(dir, "residual_histogram.svg")) << residual_histogram_svg(s);
    *h << "<h2>Residuals against the images' noise</h2>\n<img src='residual_histogram.svg'>\n"
          "<p class='note'>At the noise the bars follow the red curve; wider bars, a misfit; a "
          "shifted peak, a bias (exposure, lamp intensity).</p>\n";
  }
  if (s.lobe.empty()) return;
  std::ofstream(join_path(dir, "lobe.svg")) << lobe_polar_svg(s.lobe);
  std::ofstream(join_path(dir, "half_vectors.svg")) << half_vector_coverage_svg(s.lobe);
  *h << "<h2>The lobe against the data</h2>\n<img src='lobe.svg'>\n<p class='note'>Polar plots "
        "in the fiber's frame: round each half disc the viewer's angle to the fiber T, outward "
        "the specular part of the green reflectance (an image's value less ambient over the lamp's "
        "irradiance, or a table's reading, less the material's diffuse part); blue the data's "
        "mean, red dashed the "
        "model's at the same points, dots the data; dashed grey the mirror cone. "
     << s.lobe.size()
     << " pixels lit by one light, spread over the views.</p>\n<h3>Half vectors the capture "
        "saw</h3>\n<img src='half_vectors.svg'>\n<p class='note'>In the fiber's frame: right "
        "along the fiber, up across it. The lobe is known where the points are.</p>\n";
}

}  // namespace

ReportSummary write_report(const ReportOptions& o) {
  const json j = json::parse(read_text_file(o.material), nullptr, false);
  if (!j.is_object() || j.value("format", "") != "aniso-material")
    throw Error(o.material + ": not a material file (format \"aniso-material\")");
  const Material material = read_material(o.material);  // refuses what the format does not allow
  const json rep = j.value("report", json::object());
  const json unc = j.value("uncertainty", json::object());
  const json noise = rep.value("uncertainty_noise_only", json::object());
  ReportSummary sum;
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>aniso report: "
    << esc(std::filesystem::path(o.material).filename().string())
    << "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;}"
       "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;text-align:"
       "right}th{background:#eee}.trouble{color:#a00}.note{color:#555}img{image-rendering:"
       "pixelated;margin:4px}figure{display:inline-block;margin:6px;max-width:270px;vertical-align:"
       "top}</style></head><body>\n";
  h << "<script>window.pageErrors = []; window.addEventListener('error', (e) => "
       "window.pageErrors.push(e.message || 'could not load ' + (e.target && (e.target.src || "
       "e.target.href))), true);</script>\n";
  h << "<h1>aniso report</h1>\n<p>Material <code>" << esc(o.material) << "</code>, model <b>"
    << esc(j.value("model", "line")) << "</b>";
  if (rep.contains("model_selection"))
    h << "; chosen by BIC: " << esc(rep["model_selection"].get<std::string>());
  h << ".</p>\n";
  // Whether the data show an anisotropic lobe at all (the fit's comparison with the isotropic part
  // alone, docs/models.md §6).
  if (rep.contains("anisotropy_test")) {
    const auto& t = rep["anisotropy_test"];
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "Anisotropy: %s. BIC %.1f for the fitted anisotropic model against %.1f for the "
                  "isotropic "
                  "part alone (Lambert + Blinn-Phong) over %zu values; the best model with a lobe "
                  "draws %.3g of the signal's energy beyond it.",
                  t.value("preferred", "") == "isotropic" ? "the data show no anisotropic lobe"
                                                          : "the data show an anisotropic lobe",
                  t.value("bic_anisotropic", 0.0), t.value("bic_isotropic", 0.0),
                  t.value("values", size_t{0}), t.value("lobe_share", 0.0));
    h << "<p id='anisotropy'>" << esc(buf) << "</p>\n";
  }
  // The parameters.
  h << "<h2>Parameters</h2>\n<p>"
    << esc(rep.value("uncertainty", std::string("sigma: one standard deviation from the images' "
                                                "noise")))
    << "</p>\n<table id='parameters'><tr><th>parameter</th><th>value</th>"
    << (rep.contains("maps_means") ? "<th>sigma of the mean over the texels</th><th>sigma of the "
                                     "global fit (noise only)</th>"
                                   : "<th>sigma (whole)</th><th>sigma (noise only)</th>")
    << "</tr>\n";
  auto row = [&](const std::string& key, const json& v, const json& s, const json& sn) {
    ++sum.parameters;
    h << "<tr><td style='text-align:left'>" << esc(key) << "</td><td class='value' data-key='"
      << esc(key) << "'>" << values(v) << "</td><td>" << (s.is_null() ? "" : values(s))
      << "</td><td>" << (sn.is_null() ? "" : values(sn)) << "</td></tr>\n";
  };
  for (const char* k : {"kd", "ks", "n", "fiber_angle_deg"})
    if (j.contains(k)) row(k, j[k], unc.value(k, json()), noise.value(k, json()));
  for (const char* block : {"isotropic", "second_fiber", "topology"})
    if (j.contains(block) && j[block].is_object())
      for (const auto& [k, v] : j[block].items())
        if (v.is_number() || v.is_array()) {
          const json ub = unc.value(block, json::object()), nb = noise.value(block, json::object());
          row(std::string(block) + "." + k, v, ub.is_object() ? ub.value(k, json()) : json(),
              nb.is_object() ? nb.value(k, json()) : json());
        }
  h << "</table>\n";
  if (rep.contains("maps_means"))
    h << "<p class='note'>" << esc(rep["maps_means"].value("note", "")) << "</p>\n";
  // Warnings (trouble) apart from notes (expected).
  const json warnings = rep.value("warnings", json::array()),
             notes = rep.value("notes", json::array());
  h << "<h2>What to look at</h2>\n";
  if (warnings.empty() && notes.empty()) h << "<p>No warning: the fit describes its data.</p>\n";
  if (!warnings.empty()) {
    h << "<h3 class='trouble'>Trouble</h3><ul>\n";
    for (const auto& w : warnings)
      h << "<li class='trouble'>" << esc(w.get<std::string>()) << "</li>\n";
    h << "</ul>\n";
  }
  if (!notes.empty()) {
    h << "<h3>Notes (expected)</h3><ul>\n";
    for (const auto& w : notes) h << "<li class='note'>" << esc(w.get<std::string>()) << "</li>\n";
    h << "</ul>\n";
  }
  sum.warnings = warnings.size(), sum.notes = notes.size();
  const std::string base = parent_dir(o.material);
  write_folder_atomically(o.out, OutputKind::kText, [&](const std::string& dir) {
    // The maps' previews, copied beside the page.
    if (j.contains("previews") && j["previews"].is_object()) {
      h << "<h2>Maps</h2>\n";
      std::filesystem::create_directories(join_path(dir, "maps"));
      for (const auto& [k, v] : j["previews"].items()) {
        if (!v.is_string() || k == "note") continue;
        const std::string from = join_path(base, v.get<std::string>());
        std::error_code ec;
        if (!std::filesystem::is_regular_file(from, ec)) continue;
        std::filesystem::copy_file(from, join_path(dir, "maps/" + k + ".png"));
        h << "<figure><img src='maps/" << esc(k) << ".png' width='256'><figcaption>" << esc(k)
          << "</figcaption></figure>\n";
        ++sum.maps;
      }
      h << "<p class='note'>" << esc(j["previews"].value("note", "")) << "</p>\n";
    }
    if (j.contains("maps") && j["maps"].is_object()) map_figures(j, base, dir, &h, &sum);
    // The correlation matrix.
    if (rep.contains("correlation") && rep["correlation"].contains("matrix")) {
      sum.correlation = true;
      std::ofstream(join_path(dir, "correlation.svg")) << correlation_svg(rep["correlation"]);
      h << "<h2>Correlation of the fitted numbers</h2>\n<img src='correlation.svg'>\n<p "
           "class='note'>"
        << esc(rep["correlation"].value("note", "")) << "</p>\n";
    }
    // How the solver got there.
    if (rep.contains("convergence") && rep["convergence"].contains("cost")) {
      std::ofstream(join_path(dir, "convergence.svg"))
          << convergence_svg(rep["convergence"]["cost"].get<std::vector<double>>());
      h << "<h2>Convergence</h2>\n<img src='convergence.svg'>\n<p class='note'>"
        << esc(rep["convergence"].value("note", "")) << " (" << esc(rep.value("solver", "")) << ", "
        << esc(rep.value("termination", "")) << ")</p>\n";
      sum.convergence = true;
    }
    // A sample table or a measured file: its readings' lobe against the fitted one.
    const bool table =
        !o.capture.empty() && (lower_ext(o.capture) == ".csv" || is_rgl_bsdf(o.capture));
    if (table) {
      const VerifySamples samples = table_samples(o.capture, material);
      capture_figures(samples, dir, &h);
      sum.lobe_points = samples.lobe.size();
    }
    // Per view against the capture.
    if (!o.capture.empty() && !table) {
      const CaptureSet set = read_capture(o.capture);
      VerifySamples samples;
      samples.view_pictures = true;
      const VerifyResult v = verify_capture(set, material, join_path(dir, "views"), &samples);
      capture_figures(samples, dir, &h);
      sum.lobe_points = samples.lobe.size();
      h << "<h2>Each view against the model</h2>\n<p>The view's image and the model's, at one "
           "exposure (the image's 99.5th percentile white); the residual: model minus image over "
           "the view's noise; off the sample grey.</p>\n"
        << residual_colour_bar_svg()
        << "<table id='views'><tr><th>view</th><th>pixels</th><th>RMS</th><th>noise</th><th>RMS "
           "/ noise</th><th>verdict</th><th>image</th><th>model</th><th>residual</th></tr>\n";
      for (size_t i = 0; i < v.views.size(); ++i) {
        const ViewError& e = v.views[i];
        h << "<tr><td>" << i << "</td><td>" << e.pixels << "</td><td>" << num(e.rms) << "</td><td>"
          << num(e.noise) << "</td><td>" << num(e.rms_over_noise()) << "</td><td>"
          << verdict(e.rms_over_noise()) << "</td>";
        for (const char* what : {"image", "model", "residual"}) {
          char name[48];
          std::snprintf(name, sizeof name, "views/%s_%03zu.png", what, i);
          h << "<td><img src='" << name << "'></td>";
        }
        h << "</tr>\n";
      }
      const size_t columns_after_verdict = 3;
      h << "<tr><th>all</th><td>" << v.overall.pixels << "</td><td>" << num(v.overall.rms)
        << "</td><td>" << num(v.overall.noise) << "</td><td>" << num(v.overall.rms_over_noise())
        << "</td><td>" << verdict(v.overall.rms_over_noise()) << "</td><td colspan='"
        << columns_after_verdict << "'></td></tr></table>\n";
      sum.views = v.views.size();
    }
    // Where the time went.
    if (rep.contains("time_breakdown_s") && rep["time_breakdown_s"].is_object()) {
      h << "<h2>Time</h2>\n<table><tr><th>phase</th><th>seconds</th></tr>\n";
      for (const auto& [k, t] : rep["time_breakdown_s"].items())
        if (t.is_number())
          h << "<tr><td>" << esc(k) << "</td><td>" << num(t.get<double>()) << "</td></tr>\n";
      h << "</table>\n";
    }
    // For a headless browser (and a reader who wonders): whether every picture loaded, and the
    // errors the page met (its own script's, and resources that failed), or none.
    h << "<script>window.addEventListener('load', () => { const bad = [...document.images]"
         ".filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute('src')); "
         "document.body.dataset.loaded = bad.length ? 'missing ' + bad.join(' ') : 'all'; "
         "document.body.dataset.errors = window.pageErrors.length ? window.pageErrors.join(' | ') "
         ": 'none'; });</script>\n</body></html>\n";
    std::ofstream(join_path(dir, "index.html")) << h.str();
  });
  return sum;
}

}  // namespace aniso
