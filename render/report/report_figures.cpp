#include "render/report/report_figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "models/material_maps.h"

namespace aniso {

namespace {

constexpr double kDeg = 180.0 / M_PI;

std::string f2(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  return b;
}
std::string g4(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

std::string svg_open(int w, int h) {
  return "<svg xmlns='http://www.w3.org/2000/svg' width='" + std::to_string(w) + "' height='" +
         std::to_string(h) + "' font-family='sans-serif' font-size='11'>\n";
}

std::string polyline(const std::vector<std::pair<double, double>>& pts, const char* colour,
                     double width, const char* extra = "") {
  if (pts.size() < 2) return "";
  std::string s = "<polyline fill='none' stroke='" + std::string(colour) + "' stroke-width='" +
                  f2(width) + "' " + extra + " points='";
  for (const auto& [x, y] : pts) s += f2(x) + "," + f2(y) + " ";
  return s + "'/>\n";
}

// Dark blue, teal, green, yellow: a perceptually ordered ramp, t in [0, 1].
void ramp(double t, float rgb[3]) {
  static const double k[4][3] = {
      {0.27, 0.00, 0.33}, {0.13, 0.56, 0.55}, {0.37, 0.79, 0.38}, {0.99, 0.91, 0.14}};
  t = std::clamp(t, 0.0, 1.0) * 3;
  const int i = std::min(2, static_cast<int>(t));
  const double a = t - i;
  for (int c = 0; c < 3; ++c) rgb[c] = static_cast<float>(k[i][c] * (1 - a) + k[i + 1][c] * a);
}

}  // namespace

std::string residual_histogram_svg(const VerifySamples& s) {
  const int W = 460, H = 260, L = 40, B = 30, T = 20;
  size_t total = s.below + s.above;
  double sum = 0, sum2 = 0, within1 = 0;
  size_t in_bins = 0;
  for (int b = 0; b < VerifySamples::kBins; ++b) {
    const double x = VerifySamples::kLow + (b + 0.5) * VerifySamples::kStep;
    const double c = static_cast<double>(s.histogram[b]);
    total += s.histogram[b], in_bins += s.histogram[b];
    sum += c * x, sum2 += c * x * x;
    if (std::abs(x) < 1) within1 += c;
  }
  const double mean = in_bins ? sum / in_bins : 0;
  const double sd = in_bins ? std::sqrt(std::max(0.0, sum2 / in_bins - mean * mean)) : 0;
  const double hi = VerifySamples::kLow + VerifySamples::kBins * VerifySamples::kStep;
  auto X = [&](double x) {
    return L + (x - VerifySamples::kLow) / (hi - VerifySamples::kLow) * (W - L - 10);
  };
  double peak = 1 / std::sqrt(2 * M_PI);
  std::vector<double> density(VerifySamples::kBins, 0);
  for (int b = 0; b < VerifySamples::kBins; ++b) {
    density[b] = total ? s.histogram[b] / (static_cast<double>(total) * VerifySamples::kStep) : 0;
    peak = std::max(peak, density[b]);
  }
  auto Y = [&](double d) { return H - B - d / (1.1 * peak) * (H - B - T); };
  std::ostringstream o;
  o << svg_open(W, H) << "<g id='histogram' data-std='" << g4(sd) << "' data-mean='" << g4(mean)
    << "' data-within1='" << g4(in_bins ? within1 / in_bins : 0) << "' data-count='" << total
    << "'>\n";
  for (int b = 0; b < VerifySamples::kBins; ++b) {
    const double x0 = X(VerifySamples::kLow + b * VerifySamples::kStep),
                 x1 = X(VerifySamples::kLow + (b + 1) * VerifySamples::kStep);
    o << "<rect x='" << f2(x0) << "' y='" << f2(Y(density[b])) << "' width='" << f2(x1 - x0)
      << "' height='" << f2(H - B - Y(density[b])) << "' fill='#8ab' stroke='#fff'/>\n";
  }
  std::vector<std::pair<double, double>> g;
  for (double x = VerifySamples::kLow; x <= hi + 1e-9; x += 0.05)
    g.push_back({X(x), Y(std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI))});
  o << polyline(g, "#c00", 1.5);
  o << "<line x1='" << L << "' y1='" << H - B << "' x2='" << W - 10 << "' y2='" << H - B
    << "' stroke='#000'/>\n";
  for (int x = -5; x <= 5; ++x)
    o << "<text x='" << f2(X(x)) << "' y='" << H - B + 14 << "' text-anchor='middle'>" << x
      << "</text>\n";
  o << "<text x='" << W / 2 << "' y='" << H - 3
    << "' text-anchor='middle'>(model - image) / noise, green</text>\n";
  o << "<text x='" << L + 4 << "' y='" << T << "'>std " << f2(sd) << " (1 at the noise); "
    << s.below << " below -5, " << s.above << " above 5; red: unit Gaussian</text>\n";
  o << "</g></svg>\n";
  return o.str();
}

std::string lobe_polar_svg(const std::vector<VerifySamples::Lobe>& lobe) {
  // The panels' centres: quartiles of the light's angle to the fiber, 10 degrees apart at least.
  std::vector<double> theta;
  for (const auto& s : lobe) theta.push_back(std::acos(std::clamp<double>(s.lt, -1, 1)) * kDeg);
  std::sort(theta.begin(), theta.end());
  std::vector<double> centres;
  for (double q : {0.125, 0.375, 0.625, 0.875}) {
    if (theta.empty()) break;
    const double c = std::round(theta[static_cast<size_t>(q * (theta.size() - 1))]);
    if (centres.empty() || c - centres.back() >= 10) centres.push_back(c);
  }
  constexpr double kHalfBand = 7.5, kBinDeg = 6;
  constexpr int kBinsPhi = 30;
  const int R = 100, PW = 2 * R + 60, PH = R + 60;
  // Each panel's points and their means per bin of the viewer's angle to the fiber.
  struct Panel {
    double c = 0, peak = 0;
    std::vector<const VerifySamples::Lobe*> in;
    std::vector<double> sd = std::vector<double>(kBinsPhi, 0), sm = sd;
    std::vector<int> cnt = std::vector<int>(kBinsPhi, 0);
  };
  std::vector<Panel> panels;
  for (double c : centres) {
    Panel p;
    p.c = c;
    for (const auto& s : lobe)
      if (std::abs(std::acos(std::clamp<double>(s.lt, -1, 1)) * kDeg - c) <= kHalfBand)
        p.in.push_back(&s);
    for (const auto* s : p.in) {
      const double phi = std::acos(std::clamp<double>(s->vt, -1, 1)) * kDeg;
      const int b = std::min(kBinsPhi - 1, static_cast<int>(phi / kBinDeg));
      p.sd[b] += s->data, p.sm[b] += s->model, ++p.cnt[b];
    }
    for (int b = 0; b < kBinsPhi; ++b)
      if (p.cnt[b] >= 3) {
        p.sd[b] /= p.cnt[b], p.sm[b] /= p.cnt[b];
        p.peak = std::max({p.peak, p.sd[b], p.sm[b]});
      }
    panels.push_back(std::move(p));
  }
  // One radial scale for every panel, and each panel's misfit over it: the largest mean (a panel
  // far from the mirror cone has next to no lobe of its own).
  double lobe_peak = 0;
  for (const Panel& p : panels) lobe_peak = std::max(lobe_peak, p.peak);
  std::ostringstream o;
  o << svg_open(std::max<int>(1, centres.size()) * PW, PH + 10);
  for (size_t k = 0; k < panels.size(); ++k) {
    const Panel& pn = panels[k];
    const double c = pn.c, peak = pn.peak;
    const auto& in = pn.in;
    const auto &sd = pn.sd, &sm = pn.sm;
    const auto& cnt = pn.cnt;
    double mis2 = 0;
    int bins = 0;
    for (int b = 0; b < kBinsPhi; ++b)
      if (cnt[b] >= 3) mis2 += (sd[b] - sm[b]) * (sd[b] - sm[b]), ++bins;
    const double misfit = lobe_peak > 0 && bins ? std::sqrt(mis2 / bins) / lobe_peak : 0;
    const double scale = lobe_peak > 0 ? R / (1.1 * lobe_peak) : 0;  // one scale for the panels
    const double cx = k * PW + PW / 2.0, cy = PH - 25;
    auto at = [&](double phi_deg, double v) {
      const double r = std::clamp(v * scale, 0.0, 1.15 * R), a = phi_deg / kDeg;
      return std::pair<double, double>{cx + r * std::cos(a), cy - r * std::sin(a)};
    };
    o << "<g class='lobe' data-center='" << c << "' data-count='" << in.size() << "' data-misfit='"
      << g4(misfit) << "' data-peak='" << g4(peak) << "'>\n";
    o << "<path d='M " << cx - R << " " << cy << " A " << R << " " << R << " 0 0 1 " << cx + R
      << " " << cy << " Z' fill='#fafafa' stroke='#999'/>\n";
    for (int a = 45; a < 180; a += 45) {
      const auto [x, y] = at(a, 1.1 * lobe_peak);
      o << "<line x1='" << cx << "' y1='" << cy << "' x2='" << f2(x) << "' y2='" << f2(y)
        << "' stroke='#ddd'/><text x='" << f2(cx + (R + 12) * std::cos(a / kDeg)) << "' y='"
        << f2(cy - (R + 6) * std::sin(a / kDeg)) << "' text-anchor='middle' fill='#777'>" << a
        << "&#176;</text>\n";
    }
    o << "<text x='" << cx + R + 4 << "' y='" << cy + 4 << "'>T</text>\n";
    if (lobe_peak > 0) {
      const auto [mx, my] = at(180 - c, 1.1 * lobe_peak);  // the mirror cone: V.T = -L.T
      o << "<line x1='" << cx << "' y1='" << cy << "' x2='" << f2(mx) << "' y2='" << f2(my)
        << "' stroke='#555' stroke-dasharray='4 3'/>\n";
      for (const auto* s : in) {
        const auto [x, y] = at(std::acos(std::clamp<double>(s->vt, -1, 1)) * kDeg, s->data);
        o << "<circle cx='" << f2(x) << "' cy='" << f2(y) << "' r='1.2' fill='#9ab' "
          << "fill-opacity='0.5'/>\n";
      }
      std::vector<std::pair<double, double>> dl, ml;
      for (int b = 0; b < kBinsPhi; ++b)
        if (cnt[b] >= 3)
          dl.push_back(at((b + 0.5) * kBinDeg, sd[b])),
              ml.push_back(at((b + 0.5) * kBinDeg, sm[b]));
      o << polyline(dl, "#1f5fbf", 2) << polyline(ml, "#d22", 2, "stroke-dasharray='6 2'");
    }
    o << "<text x='" << cx << "' y='" << 14 << "' text-anchor='middle'>light at " << c
      << "&#176; &#177; " << kHalfBand << "&#176; to the fiber: " << in.size()
      << " points</text>\n<text x='" << cx << "' y='" << PH + 4
      << "' text-anchor='middle' fill='#555'>misfit " << f2(100 * misfit)
      << " % of the lobe's peak</text>\n</g>\n";
  }
  o << "</svg>\n";
  return o.str();
}

std::string half_vector_coverage_svg(const std::vector<VerifySamples::Lobe>& lobe) {
  const int R = 120, S = 2 * R + 40;
  const double c = S / 2.0;
  std::ostringstream o;
  o << svg_open(S, S) << "<g id='coverage' data-count='" << lobe.size() << "'>\n";
  o << "<circle cx='" << c << "' cy='" << c << "' r='" << R << "' fill='#fafafa' stroke='#999'/>\n"
    << "<line x1='" << c - R << "' y1='" << c << "' x2='" << c + R << "' y2='" << c
    << "' stroke='#ddd'/><line x1='" << c << "' y1='" << c - R << "' x2='" << c << "' y2='" << c + R
    << "' stroke='#ddd'/>\n";
  for (const auto& s : lobe)
    o << "<circle cx='" << f2(c + R * s.ht) << "' cy='" << f2(c - R * s.hb)
      << "' r='1.2' fill='#1f5fbf' fill-opacity='0.35'/>\n";
  o << "<text x='" << c + R + 4 << "' y='" << c + 4 << "'>H.T</text><text x='" << c - 12 << "' y='"
    << c - R - 6 << "'>H.B</text>\n</g></svg>\n";
  return o.str();
}

std::string convergence_svg(const std::vector<double>& cost) {
  const int W = 460, H = 240, L = 70, B = 30, T = 15;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : cost)
    if (v > 0) lo = std::min(lo, v), hi = std::max(hi, v);
  std::ostringstream o;
  o << svg_open(W, H) << "<g id='convergence' data-steps='" << (cost.empty() ? 0 : cost.size() - 1)
    << "' data-first='" << (cost.empty() ? 0 : cost.front()) << "' data-last='"
    << (cost.empty() ? 0 : cost.back()) << "'>\n";
  if (cost.size() >= 1 && hi >= lo) {
    // A log axis over decades where the cost fell by 10 or more, else a linear one over its range.
    const bool log = hi >= 10 * lo;
    const double l0 = log ? std::floor(std::log10(lo)) : lo - 0.05 * (hi - lo) - 1e-12 * hi;
    const double l1 =
        log ? std::max(l0 + 1, std::ceil(std::log10(hi))) : hi + 0.05 * (hi - lo) + 1e-12 * hi;
    const double n = std::max<double>(1, cost.size() - 1);
    auto X = [&](double i) { return L + i / n * (W - L - 15); };
    auto Y = [&](double v) {
      const double t = log ? std::log10(std::max(v, std::pow(10.0, l0))) : v;
      return H - B - (t - l0) / (l1 - l0) * (H - B - T);
    };
    std::vector<std::pair<double, double>> pts;
    for (size_t i = 0; i < cost.size(); ++i) pts.push_back({X(i), Y(cost[i])});
    o << polyline(pts, "#1f5fbf", 1.5);
    for (const auto& [x, y] : pts)
      o << "<circle cx='" << f2(x) << "' cy='" << f2(y) << "' r='2' fill='#1f5fbf'/>\n";
    if (log)
      for (double e = l0; e <= l1; ++e)
        o << "<text x='" << L - 4 << "' y='" << f2(Y(std::pow(10, e)) + 4)
          << "' text-anchor='end'>1e" << static_cast<int>(e) << "</text>\n";
    else
      for (double v : {lo, hi})
        o << "<text x='" << L - 4 << "' y='" << f2(Y(v) + 4) << "' text-anchor='end'>" << g4(v)
          << "</text>\n";
    o << "<line x1='" << L << "' y1='" << H - B << "' x2='" << W - 15 << "' y2='" << H - B
      << "' stroke='#000'/><line x1='" << L << "' y1='" << T << "' x2='" << L << "' y2='" << H - B
      << "' stroke='#000'/>\n<text x='" << L << "' y='" << H - B + 14 << "'>0</text><text x='"
      << W - 15 << "' y='" << H - B + 14 << "' text-anchor='end'>" << cost.size() - 1
      << "</text><text x='" << (L + W) / 2 << "' y='" << H - 3
      << "' text-anchor='middle'>accepted step</text>\n";
  }
  o << "</g></svg>\n";
  return o.str();
}

std::string direction_field_svg(const Image& fiber, const Image* determined) {
  const int gw = std::min(fiber.width, 40), gh = std::min(fiber.height, 40);
  const double cell = std::max(8.0, 480.0 / std::max(gw, gh));
  std::ostringstream o;
  o << svg_open(static_cast<int>(gw * cell), static_cast<int>(gh * cell))
    << "<rect width='100%' height='100%' fill='#fafafa'/>\n<g id='direction-field' data-glyphs='"
    << gw * gh << "'>\n";
  for (int j = 0; j < gh; ++j)
    for (int i = 0; i < gw; ++i) {
      const double u = (i + 0.5) / gw, v = (j + 0.5) / gh;
      const double c2 = map_lookup(fiber, u, v, 0, false), s2 = map_lookup(fiber, u, v, 1, false);
      const double psi = 0.5 * std::atan2(s2, c2);
      const bool known = !determined || map_lookup(*determined, u, v, 0, false) >= 0.5;
      const double x = (i + 0.5) * cell, y = (j + 0.5) * cell, h = 0.42 * cell;
      o << "<line x1='" << f2(x - h * std::cos(psi)) << "' y1='" << f2(y - h * std::sin(psi))
        << "' x2='" << f2(x + h * std::cos(psi)) << "' y2='" << f2(y + h * std::sin(psi))
        << "' stroke='" << (known ? "#123" : "#ccc") << "' stroke-width='1.6' data-psi='"
        << f2(std::fmod(psi * kDeg + 180, 180)) << "'/>\n";
    }
  o << "</g></svg>\n";
  return o.str();
}

std::string residual_colour_bar_svg() {
  std::ostringstream o;
  o << svg_open(340, 34) << "<defs><linearGradient id='rb'><stop offset='0' stop-color='#00f'/>"
    << "<stop offset='0.5' stop-color='#fff'/><stop offset='1' stop-color='#f00'/>"
    << "</linearGradient></defs><rect x='20' y='2' width='300' height='12' fill='url(#rb)' "
    << "stroke='#999'/>\n";
  for (int k = -3; k <= 3; ++k)
    o << "<text x='" << 20 + (k + 3) * 50 << "' y='28' text-anchor='middle'>" << k
      << (k ? "&#963;" : "") << "</text>\n";
  o << "</svg>\n";
  return o.str();
}

Image scalar_map_picture(const Image& img, bool log, double* lo, double* hi) {
  constexpr double kUnknown = 0.5 * std::numeric_limits<float>::max();
  *lo = std::numeric_limits<double>::infinity(), *hi = -*lo;
  for (size_t i = 0; i < img.px.size(); i += img.channels) {
    const double v = img.px[i];
    if (!std::isfinite(v) || std::abs(v) >= kUnknown || (log && !(v > 0))) continue;
    *lo = std::min(*lo, v), *hi = std::max(*hi, v);
  }
  if (!(*hi >= *lo)) *lo = *hi = 0;
  const int scale = std::max(1, (256 + std::min(img.width, img.height) - 1) /
                                    std::max(1, std::min(img.width, img.height)));
  Image out(img.width * scale, img.height * scale, 3, 0.5f);
  const double a = log && *lo > 0 ? std::log(*lo) : *lo, b = log && *hi > 0 ? std::log(*hi) : *hi;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const double v = img.at(x, y, 0);
      float rgb[3] = {0.5f, 0.5f, 0.5f};
      if (std::isfinite(v) && std::abs(v) < kUnknown && (!log || v > 0))
        ramp(b > a ? ((log ? std::log(v) : v) - a) / (b - a) : 0.5, rgb);
      for (int dy = 0; dy < scale; ++dy)
        for (int dx = 0; dx < scale; ++dx)
          for (int c = 0; c < 3; ++c) out.at(x * scale + dx, y * scale + dy, c) = rgb[c];
    }
  return out;
}

}  // namespace aniso
