#include "photo/lamps/lamps.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "photo/shoot/calibrate.h"

namespace aniso {

namespace {

// The board drawn at 0.1 mm a pixel: fine enough to test a point's clearance from the ink.
constexpr double kDrawnMm = 0.1;

// Points along the centre line of each square's white ring (between the marker and the square's
// edge), about kSpacingM apart, that have white paper at least `clear` metres all round.
constexpr double kSpacingM = 0.002;

}  // namespace

PaperPoints::PaperPoints(const BoardSpec& b, const std::vector<std::array<double, 2>>& polygon,
                         double keep_away_m, const std::vector<std::array<double, 2>>& card) {
  auto near = [&](const std::vector<std::array<double, 2>>& outline, double x, double y) {
    return !outline.empty() &&
           (inside_polygon(outline, x, y) || distance_to_outline(outline, x, y) < keep_away_m);
  };
  const double dpi = 0.0254 / (kDrawnMm * 1e-3);
  const Image drawn = render_board(b, dpi);
  const double px_per_m = drawn.width / (b.squares_x * b.square_m);
  const double gap = 0.5 * (b.square_m - b.marker_m);
  // The ring's half width less what a pixel's blur and the corners' error reach.
  const double clear = std::max(0.4 * gap, 0.5 * gap - 0.0006);
  const int r = std::max(1, static_cast<int>(clear * px_per_m));
  auto paper = [&](double x, double y) {
    const int cx = static_cast<int>(x * px_per_m), cy = static_cast<int>(y * px_per_m);
    if (cx - r < 0 || cy - r < 0 || cx + r >= drawn.width || cy + r >= drawn.height) return false;
    for (int dy = -r; dy <= r; dy += std::max(1, r / 4))
      for (int dx = -r; dx <= r; dx += std::max(1, r / 4))
        if (drawn.at(cx + dx, cy + dy, 0) < 0.5f) return false;
    return drawn.at(cx + r, cy + r, 0) > 0.5f && drawn.at(cx - r, cy - r, 0) > 0.5f;
  };
  const double side = b.square_m - gap;  // the ring's centre line, a square of this side
  const int per_side = std::max(2, static_cast<int>(side / kSpacingM));
  for (int j = 1; j + 1 < b.squares_y; ++j)
    for (int i = 1; i + 1 < b.squares_x; ++i) {
      const double x0 = i * b.square_m + 0.5 * gap, y0 = j * b.square_m + 0.5 * gap;
      for (int e = 0; e < 4; ++e)
        for (int k = 0; k < per_side; ++k) {
          const double t = side * k / per_side;
          const double x = e == 0 ? x0 + t : e == 1 ? x0 + side : e == 2 ? x0 + side - t : x0;
          const double y = e == 0 ? y0 : e == 1 ? y0 + t : e == 2 ? y0 + side : y0 + side - t;
          if (near(polygon, x, y) || near(card, x, y)) continue;
          if (paper(x, y)) points_.push_back({x, y, i, j, 0.5 * gap});
        }
    }
}

namespace {

// Board point (x, y) through the homography H (board metres to pixels): its pixel (u, v) and the
// size on the board of a pixel there along its longest side (metres), 1 / the smallest singular
// value of the homography's Jacobian. False where the point is behind the camera.
bool project(const cv::Mat& H, double x, double y, double* u, double* v, double* pixel_m) {
  const double w = H.at<double>(2, 0) * x + H.at<double>(2, 1) * y + H.at<double>(2, 2);
  if (!(w > 0)) return false;
  *u = (H.at<double>(0, 0) * x + H.at<double>(0, 1) * y + H.at<double>(0, 2)) / w;
  *v = (H.at<double>(1, 0) * x + H.at<double>(1, 1) * y + H.at<double>(1, 2)) / w;
  const double h00 = H.at<double>(0, 0), h01 = H.at<double>(0, 1), h10 = H.at<double>(1, 0),
               h11 = H.at<double>(1, 1), h20 = H.at<double>(2, 0), h21 = H.at<double>(2, 1);
  const double j00 = (h00 - *u * h20) / w, j01 = (h01 - *u * h21) / w, j10 = (h10 - *v * h20) / w,
               j11 = (h11 - *v * h21) / w;
  const double fro = j00 * j00 + j01 * j01 + j10 * j10 + j11 * j11,
               det = std::abs(j00 * j11 - j01 * j10);
  const double smin2 = 0.5 * (fro - std::sqrt(std::max(fro * fro - 4 * det * det, 0.0)));
  if (!(smin2 > 0)) return false;
  *pixel_m = 1 / std::sqrt(smin2);
  return true;
}

// The image's RGB at pixel (u, v), bilinear; false off the image, at a clipped pixel or where a
// channel is not a positive number.
bool read_pixel(const Image& rgb, const std::vector<uint8_t>& saturated, double u, double v,
                float out[3]) {
  const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= rgb.width || y0 + 1 >= rgb.height) return false;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx)
      if (!saturated.empty() && saturated[static_cast<size_t>(y0 + dy) * rgb.width + x0 + dx] != 0)
        return false;
  const double tx = u - x0, ty = v - y0;
  for (int c = 0; c < 3; ++c) {
    const double val = (1 - tx) * (1 - ty) * rgb.at(x0, y0, c) +
                       tx * (1 - ty) * rgb.at(x0 + 1, y0, c) +
                       (1 - tx) * ty * rgb.at(x0, y0 + 1, c) + tx * ty * rgb.at(x0 + 1, y0 + 1, c);
    if (!(std::isfinite(val) && val > 0)) return false;
    out[c] = static_cast<float>(val);
  }
  return true;
}

// The detected corners' board positions (metres) beside their pixels.
struct CornerPairs {
  std::vector<cv::Point2f> board, pixel;
  std::vector<BoardCorner> corner;
};
CornerPairs corner_pairs(const BoardSpec& b, const std::vector<BoardCorner>& corners) {
  const auto obj = board_corners_m(b);
  CornerPairs out;
  for (const auto& c : corners) {
    if (c.id < 0 || static_cast<size_t>(c.id) >= obj.size()) continue;
    out.board.emplace_back(static_cast<float>(obj[c.id][0]), static_cast<float>(obj[c.id][1]));
    out.pixel.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
    out.corner.push_back(c);
  }
  return out;
}

}  // namespace

std::vector<PaperSample> paper_samples(const BoardSpec& b, const PaperPoints& where,
                                       const std::vector<BoardCorner>& corners, const Image& rgb,
                                       const std::vector<uint8_t>& saturated) {
  // Corner (gi, gj) of the lattice (inner corners: 1 .. squares - 1) by its board position.
  const CornerPairs pairs = corner_pairs(b, corners);
  std::map<std::pair<int, int>, std::array<double, 2>> px;
  for (size_t k = 0; k < pairs.board.size(); ++k) {
    const int gi = static_cast<int>(std::lround(pairs.board[k].x / b.square_m));
    const int gj = static_cast<int>(std::lround(pairs.board[k].y / b.square_m));
    px[{gi, gj}] = {pairs.pixel[k].x, pairs.pixel[k].y};
  }
  std::vector<PaperSample> out;
  std::map<std::pair<int, int>, cv::Mat> cells;  // each cell's homography, once
  for (const auto& p : where.points()) {
    const std::pair<int, int> key{p.i, p.j};
    auto it = cells.find(key);
    if (it == cells.end()) {
      cv::Mat H;
      std::vector<cv::Point2f> from, to;
      for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di) {
          const auto c = px.find({p.i + di, p.j + dj});
          if (c == px.end()) break;
          from.emplace_back(static_cast<float>((p.i + di) * b.square_m),
                            static_cast<float>((p.j + dj) * b.square_m));
          to.emplace_back(static_cast<float>(c->second[0]), static_cast<float>(c->second[1]));
        }
      if (from.size() == 4) H = cv::getPerspectiveTransform(from, to);
      it = cells.emplace(key, H).first;
    }
    if (it->second.empty()) continue;
    double u, v, pixel_m;
    if (!project(it->second, p.x, p.y, &u, &v, &pixel_m) || kReachPixels * pixel_m > p.clear)
      continue;
    PaperSample s;
    s.x = p.x, s.y = p.y;
    s.u = static_cast<float>(u), s.v = static_cast<float>(v);
    if (read_pixel(rgb, saturated, u, v, s.rgb)) out.push_back(s);
  }
  return out;
}

std::vector<PaperSample> card_samples(const BoardSpec& b,
                                      const std::vector<std::array<double, 2>>& card,
                                      const std::vector<BoardCorner>& corners, const Image& rgb,
                                      const std::vector<uint8_t>& saturated) {
  if (card.empty()) return {};
  double cx = 0, cy = 0, x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const auto& p : card) {
    cx += p[0] / card.size(), cy += p[1] / card.size();
    x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::min(y0, p[1]),
    y1 = std::max(y1, p[1]);
  }
  // The corners nearest the card: a homography over them bends with the lens as little as the
  // card's own neighbourhood does.
  constexpr size_t kNearCorners = 16, kMinCorners = 8;
  const CornerPairs all = corner_pairs(b, corners);
  std::vector<std::pair<double, size_t>> by_distance;
  for (size_t k = 0; k < all.board.size(); ++k)
    by_distance.push_back({std::hypot(all.board[k].x - cx, all.board[k].y - cy), k});
  if (by_distance.size() < kMinCorners) return {};
  const size_t n = std::min(kNearCorners, by_distance.size());
  std::partial_sort(by_distance.begin(), by_distance.begin() + n, by_distance.end());
  std::vector<BoardCorner> nearest;
  std::vector<cv::Point2f> from, to;
  for (size_t k = 0; k < n; ++k) {
    nearest.push_back(all.corner[by_distance[k].second]);
    from.push_back(all.board[by_distance[k].second]);
    to.push_back(all.pixel[by_distance[k].second]);
  }
  std::array<double, 9> h;
  if (!board_homography(nearest, b, &h)) return {};
  const cv::Mat H = cv::Mat(3, 3, CV_64F, h.data()).clone();
  double worst_px = 0;
  for (size_t k = 0; k < n; ++k) {
    double u, v, pixel_m;
    if (!project(H, from[k].x, from[k].y, &u, &v, &pixel_m)) return {};
    worst_px = std::max(worst_px, std::hypot(u - to[k].x, v - to[k].y));
  }
  constexpr double kStepM = 0.002, kEdgeM = 0.003;
  std::vector<PaperSample> out;
  for (double y = y0 + 0.5 * kStepM; y < y1; y += kStepM)
    for (double x = x0 + 0.5 * kStepM; x < x1; x += kStepM) {
      if (!inside_polygon(card, x, y)) continue;
      double u, v, pixel_m;
      if (!project(H, x, y, &u, &v, &pixel_m)) continue;
      if (distance_to_outline(card, x, y) < kEdgeM + (kReachPixels + 2 * worst_px) * pixel_m)
        continue;
      PaperSample s;
      s.x = x, s.y = y;
      s.u = static_cast<float>(u), s.v = static_cast<float>(v);
      if (read_pixel(rgb, saturated, u, v, s.rgb)) out.push_back(s);
    }
  return out;
}

namespace {

// The median reading of the samples per channel (at least 1e-12): each channel's scale.
void channel_medians(const std::vector<PaperSample>& samples, double med[3]) {
  for (int c = 0; c < 3; ++c) {
    std::vector<double> v;
    v.reserve(samples.size());
    for (const auto& sm : samples) v.push_back(sm.rgb[c]);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    med[c] = v.empty() ? 1e-12 : std::max(v[v.size() / 2], 1e-12);
  }
}

// The options of the lamps' solves: small problems, quiet.
ceres::Solver::Options lamp_solver(ceres::LinearSolverType linear) {
  ceres::Solver::Options so;
  so.max_num_iterations = 100;
  so.linear_solver_type = linear;
  so.logging_type = ceres::SILENT;
  return so;
}

// The paper's shading at board point (x, y) per unit of rho I / pi: h / r^3 for the lamp at p
// (z < 0 on the printed side); T a double or a Ceres Jet.
template <class T>
T shading(const T* p, double x, double y) {
  using std::sqrt;
  const T dx = p[0] - x, dy = p[1] - y, h = -p[2];
  const T d2 = dx * dx + dy * dy + h * h;
  return h / (d2 * sqrt(d2));
}

// One paper point's three channels: (A_c h / r^3 - v_c) / s_c, A_c = rho_c I_c / pi.
struct PaperCost {
  double x, y, v[3], inv_s[3];
  template <class T>
  bool operator()(const T* p, const T* a, T* r) const {
    const T g = shading(p, x, y);
    for (int c = 0; c < 3; ++c) r[c] = (a[c] * g - v[c]) * inv_s[c];
    return true;
  }
};

// The written position as a measurement of sigma metres per axis.
struct PriorCost {
  double w[3], inv_sigma;
  template <class T>
  bool operator()(const T* p, T* r) const {
    for (int k = 0; k < 3; ++k) r[k] = (p[k] - w[k]) * inv_sigma;
    return true;
  }
};

// A_c in closed form at p (least squares over the points).
void intensity_at(const std::vector<PaperSample>& paper, const double p[3], double a[3]) {
  double gg = 0, gv[3] = {0, 0, 0};
  for (const auto& s : paper) {
    const double g = shading(p, s.x, s.y);
    gg += g * g;
    for (int c = 0; c < 3; ++c) gv[c] += g * s.rgb[c];
  }
  for (int c = 0; c < 3; ++c) a[c] = gg > 0 ? gv[c] / gg : 0;
}

// The robust relative spread of the samples' readings about a model of them, 1.4826 MAD of
// |v / m - 1| over every channel the model holds positive; `model(sample, m)` fills m[3]. NaN where
// it holds none.
template <class Model>
double spread_about(const std::vector<PaperSample>& samples, const Model& model) {
  std::vector<double> e;
  e.reserve(3 * samples.size());
  for (const auto& s : samples) {
    double m[3];
    model(s, m);
    for (int c = 0; c < 3; ++c)
      if (m[c] > 0) e.push_back(std::abs(s.rgb[c] / m[c] - 1));
  }
  if (e.empty()) return NAN;
  std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
  return 1.4826 * e[e.size() / 2];
}

// The spread of the paper about the shading at p, a (1 where nothing is lit).
double relative_spread(const std::vector<PaperSample>& paper, const double p[3],
                       const double a[3]) {
  const double s = spread_about(paper, [&](const PaperSample& sm, double m[3]) {
    const double g = shading(p, sm.x, sm.y);
    for (int c = 0; c < 3; ++c) m[c] = a[c] * g;
  });
  return std::isnan(s) ? 1 : s;
}

}  // namespace

namespace {

// One solve of a lamp from the paper: p from `start`, with the prior N(centre, sigma^2) per axis,
// twice (the data's weight from their spread about the first solution, a guess of 2 % for it);
// a, the spread and the covariance of p with it. False where it does not settle.
struct PaperSolve {
  double p[3], a[3], cov[9], spread = 0.02;
  std::string why;
};
bool solve_lamp(const std::vector<PaperSample>& paper, const Vec3& start, const Vec3& centre,
                double sigma, double sample_height_m, PaperSolve* out) {
  double* p = out->p;
  double* a = out->a;
  p[0] = start.x, p[1] = start.y, p[2] = start.z;
  intensity_at(paper, p, a);
  double med[3];
  channel_medians(paper, med);
  ceres::Solver::Summary summary;
  std::unique_ptr<ceres::Problem> pb;
  for (int pass = 0; pass < 2; ++pass) {
    ceres::Problem::Options po;
    pb = std::make_unique<ceres::Problem>(po);
    for (const auto& s : paper) {
      auto* cost = new PaperCost{s.x, s.y, {s.rgb[0], s.rgb[1], s.rgb[2]}, {}};
      for (int c = 0; c < 3; ++c) cost->inv_s[c] = 1.0 / (out->spread * med[c]);
      pb->AddResidualBlock(new ceres::AutoDiffCostFunction<PaperCost, 3, 3, 3>(cost),
                           new ceres::CauchyLoss(3.0), p, a);
    }
    pb->AddResidualBlock(new ceres::AutoDiffCostFunction<PriorCost, 3, 3>(
                             new PriorCost{{centre.x, centre.y, centre.z}, 1 / sigma}),
                         nullptr, p);
    // The lamp above the sample's surface, at least a centimetre.
    pb->SetParameterUpperBound(p, 2, -sample_height_m - 0.01);
    const ceres::Solver::Options so = lamp_solver(ceres::DENSE_QR);
    ceres::Solve(so, pb.get(), &summary);
    out->spread = std::max(relative_spread(paper, p, a), 1e-4);
  }
  if (!summary.IsSolutionUsable() || !std::isfinite(p[0] + p[1] + p[2] + a[0] + a[1] + a[2])) {
    out->why = "the paper's shading did not settle (" + summary.message + ")";
    return false;
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance cov(co);
  if (!cov.Compute(std::vector<const double*>{p}, pb.get()) ||
      !cov.GetCovarianceBlock(p, p, out->cov)) {
    out->why = "the paper's shading leaves the position undetermined";
    return false;
  }
  return true;
}

// Squared Mahalanobis distance of w from the paper-alone position: its covariance and the written
// position's sigma^2 together.
double mahalanobis2(const PaperSolve& alone, const Vec3& w, double sigma) {
  Eigen::Matrix3d c;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) c(r, k) = alone.cov[3 * r + k] + (r == k ? sigma * sigma : 0);
  const Eigen::Vector3d d(w.x - alone.p[0], w.y - alone.p[1], w.z - alone.p[2]);
  return d.dot(c.ldlt().solve(d));
}

// The paper alone: a prior this wide only keeps a lamp the board cannot place from running off.
constexpr double kPaperAloneSigmaM = 0.5;

}  // namespace

LampFound find_lamp(const std::vector<PaperSample>& paper, const Light& light, double sigma_m,
                    const RGB& rho, double sample_height_m, const std::vector<Vec3>& alternatives) {
  LampFound f;
  f.written = light.position;
  f.found = light.position;
  f.written_intensity = light.intensity;
  f.found_intensity = light.intensity;
  f.prior_sigma_m = sigma_m;
  f.points = paper.size();
  if (!inverse_square_point(light)) {
    f.why = light.type != Light::Type::kPoint ? "not a point lamp"
                                              : "its attenuation is not the inverse square";
    return f;
  }
  constexpr size_t kMinPoints = 60;
  if (paper.size() < kMinPoints) {
    f.why = "too little of the board's paper in view (" + std::to_string(paper.size()) +
            " points, " + std::to_string(kMinPoints) + " needed)";
    return f;
  }
  // The paper alone first: does the written position agree with it?
  PaperSolve alone, map;
  if (!solve_lamp(paper, light.position, light.position, kPaperAloneSigmaM, sample_height_m,
                  &alone)) {
    f.why = alone.why;
    return f;
  }
  f.alone = {alone.p[0], alone.p[1], alone.p[2]};
  f.disagreement = std::sqrt(mahalanobis2(alone, light.position, sigma_m));
  for (size_t k = 0; k < alternatives.size(); ++k)
    if (std::sqrt(mahalanobis2(alone, alternatives[k], sigma_m)) < kDisagreeSigmas)
      f.agrees_with.push_back(static_cast<int>(k));
  // Written and paper agree: both together. Otherwise the written position is not a measurement
  // of this lamp, and the paper alone places it.
  const bool agree = f.disagreement < kDisagreeSigmas;
  const PaperSolve* use = &alone;
  if (agree) {
    if (!solve_lamp(paper, f.alone, light.position, sigma_m, sample_height_m, &map)) {
      f.why = map.why;
      return f;
    }
    use = &map;
  }
  f.solved = true;
  f.found = {use->p[0], use->p[1], use->p[2]};
  for (int k = 0; k < 3; ++k) f.sigma_m[k] = std::sqrt(std::max(use->cov[4 * k], 0.0));
  for (int c = 0; c < 3; ++c) {
    f.found_intensity[c] = use->a[c] * M_PI / rho[c];
    f.paper_amplitude[c] = use->a[c];
  }
  f.paper_rms = use->spread;
  f.moved_sigmas = length(f.found - f.written) / sigma_m;
  return f;
}

void read_card(const std::vector<PaperSample>& card, std::vector<LampFound>* lamps) {
  for (auto& f : *lamps) f.card_points = 0;
  if (card.size() < kMinCardPoints || lamps->empty()) return;
  for (const auto& f : *lamps)
    if (!f.solved) return;
  // The paper's shading under every lamp, sum_k A_k h_k / r_k^3, per channel at each card point;
  // the card reads c times it, c = rho_card / rho_paper.
  auto paper_at = [&](const PaperSample& sm, int ch) {
    double sum = 0;
    for (const auto& f : *lamps) {
      const double p[3] = {f.found.x, f.found.y, f.found.z};
      sum += f.paper_amplitude[ch] * shading(p, sm.x, sm.y);
    }
    return sum;
  };
  double c[3];
  for (int ch = 0; ch < 3; ++ch) {
    double ss = 0, sv = 0;
    for (const auto& sm : card) {
      const double g = paper_at(sm, ch);
      ss += g * g, sv += g * sm.rgb[ch];
    }
    c[ch] = ss > 0 ? sv / ss : 0;
  }
  const double spread = spread_about(card, [&](const PaperSample& sm, double m[3]) {
    for (int ch = 0; ch < 3; ++ch) m[ch] = c[ch] * paper_at(sm, ch);
  });
  constexpr double kEvenCard = 0.1;  // NaN (nothing lit) fails it too
  if (!(c[0] > 0 && c[1] > 0 && c[2] > 0) || !(spread < kEvenCard)) return;
  // One reading of the photo, kept on its first lamp.
  LampFound& f = lamps->front();
  for (int ch = 0; ch < 3; ++ch) f.card_amplitude[ch] = c[ch] * f.paper_amplitude[ch];
  f.card_points = card.size();
  f.card_rms = spread;
}

namespace {

// One paper point under several lamps: (sum_k A_k,c h_k / r_k^3 - v_c) / s_c, the parameter
// blocks each lamp's position and A in turn.
struct MultiPaperCost {
  double x, y, v[3], inv_s[3];
  int lamps;
  template <class T>
  bool operator()(T const* const* q, T* r) const {
    T sum[3] = {T(0), T(0), T(0)};
    for (int k = 0; k < lamps; ++k) {
      const T g = shading(q[2 * k], x, y);
      for (int c = 0; c < 3; ++c) sum[c] += q[2 * k + 1][c] * g;
    }
    for (int c = 0; c < 3; ++c) r[c] = (sum[c] - v[c]) * inv_s[c];
    return true;
  }
};

}  // namespace

std::vector<LampFound> find_lamps_together(const std::vector<PaperSample>& paper,
                                           const std::vector<Light>& lights,
                                           const std::vector<double>& sigma_m, const RGB& rho,
                                           double sample_height_m) {
  const size_t K = lights.size();
  std::vector<LampFound> out(K);
  for (size_t k = 0; k < K; ++k) {
    LampFound& f = out[k];
    f.written = f.found = f.alone = lights[k].position;
    f.written_intensity = f.found_intensity = lights[k].intensity;
    f.prior_sigma_m = sigma_m[k];
    f.points = paper.size();
  }
  auto fail = [&](const std::string& why) {
    for (auto& f : out) f.why = why;
    return out;
  };
  for (const Light& l : lights)
    if (!inverse_square_point(l))
      return fail("the photo's lights are not all point lamps of inverse-square falloff");
  constexpr size_t kMinPointsPerLamp = 60;
  if (paper.size() < kMinPointsPerLamp * K)
    return fail("too little of the board's paper in view for " + std::to_string(K) + " lamps (" +
                std::to_string(paper.size()) + " points)");
  std::vector<std::array<double, 3>> p(K), a(K);
  for (size_t k = 0; k < K; ++k)
    p[k] = {lights[k].position.x, lights[k].position.y, lights[k].position.z};
  // A per channel in closed form at the written positions: K x K least squares.
  for (int c = 0; c < 3; ++c) {
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(K, K);
    Eigen::VectorXd gv = Eigen::VectorXd::Zero(K);
    for (const auto& sm : paper) {
      Eigen::VectorXd g(K);
      for (size_t k = 0; k < K; ++k) g[k] = shading(p[k].data(), sm.x, sm.y);
      G += g * g.transpose();
      gv += g * static_cast<double>(sm.rgb[c]);
    }
    const Eigen::VectorXd x = G.ldlt().solve(gv);
    for (size_t k = 0; k < K; ++k) a[k][c] = std::max(x[k], 1e-9);
  }
  double med[3];
  channel_medians(paper, med);
  double spread = 0.02;
  std::unique_ptr<ceres::Problem> pb;
  ceres::Solver::Summary summary;
  for (int pass = 0; pass < 2; ++pass) {
    pb = std::make_unique<ceres::Problem>();
    for (const auto& sm : paper) {
      auto* f = new ceres::DynamicAutoDiffCostFunction<MultiPaperCost, 6>(
          new MultiPaperCost{sm.x,
                             sm.y,
                             {sm.rgb[0], sm.rgb[1], sm.rgb[2]},
                             {1 / (spread * med[0]), 1 / (spread * med[1]), 1 / (spread * med[2])},
                             static_cast<int>(K)});
      std::vector<double*> blocks;
      for (size_t k = 0; k < K; ++k) {
        f->AddParameterBlock(3);
        f->AddParameterBlock(3);
        blocks.push_back(p[k].data());
        blocks.push_back(a[k].data());
      }
      f->SetNumResiduals(3);
      pb->AddResidualBlock(f, new ceres::CauchyLoss(3.0), blocks);
    }
    for (size_t k = 0; k < K; ++k) {
      const Vec3& w = lights[k].position;
      pb->AddResidualBlock(new ceres::AutoDiffCostFunction<PriorCost, 3, 3>(
                               new PriorCost{{w.x, w.y, w.z}, 1 / sigma_m[k]}),
                           nullptr, p[k].data());
      pb->SetParameterUpperBound(p[k].data(), 2, -sample_height_m - 0.01);
    }
    const ceres::Solver::Options so = lamp_solver(ceres::DENSE_QR);
    ceres::Solve(so, pb.get(), &summary);
    // The spread of the paper about the lamps' summed shading.
    const double s = spread_about(paper, [&](const PaperSample& sm, double m[3]) {
      m[0] = m[1] = m[2] = 0;
      for (size_t k = 0; k < K; ++k) {
        const double g = shading(p[k].data(), sm.x, sm.y);
        for (int c = 0; c < 3; ++c) m[c] += a[k][c] * g;
      }
    });
    if (!std::isnan(s)) spread = std::max(s, 1e-4);
  }
  if (!summary.IsSolutionUsable())
    return fail("the paper's shading did not settle (" + summary.message + ")");
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (size_t k = 0; k < K; ++k) pairs.push_back({p[k].data(), p[k].data()});
  if (!cov.Compute(pairs, pb.get()))
    return fail("the paper's shading leaves the lamps undetermined");
  for (size_t k = 0; k < K; ++k) {
    double ck[9];
    if (!cov.GetCovarianceBlock(p[k].data(), p[k].data(), ck))
      return fail("the paper's shading leaves the lamps undetermined");
    LampFound& f = out[k];
    f.solved = true;
    f.found = f.alone = {p[k][0], p[k][1], p[k][2]};
    for (int i = 0; i < 3; ++i) f.sigma_m[i] = std::sqrt(std::max(ck[4 * i], 0.0));
    for (int c = 0; c < 3; ++c) {
      f.found_intensity[c] = a[k][c] * M_PI / rho[c];
      f.paper_amplitude[c] = a[k][c];
    }
    f.paper_rms = spread;
    f.moved_sigmas = length(f.found - f.written) / sigma_m[k];
    f.disagreement = f.moved_sigmas;
  }
  return out;
}

PaperFromCard paper_from_card(const std::vector<const LampFound*>& lamps, const RGB& card_rho) {
  PaperFromCard out;
  std::array<std::vector<double>, 3> ratio;
  for (const LampFound* f : lamps) {
    if (!f->solved || f->card_points == 0) continue;
    for (int c = 0; c < 3; ++c)
      ratio[c].push_back(card_rho[c] * f->paper_amplitude[c] / f->card_amplitude[c]);
    ++out.photos;
    out.points += f->card_points;
  }
  if (out.photos == 0) return out;
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  for (int c = 0; c < 3; ++c) {
    out.paper[c] = median(ratio[c]);
    std::vector<double> dev;
    for (double r : ratio[c]) dev.push_back(std::abs(r - out.paper[c]));
    out.sigma[c] = 1.4826 * median(dev) / std::sqrt(static_cast<double>(ratio[c].size()));
  }
  out.found = true;
  return out;
}

namespace {

// One paper point under a lamp through the lens's V: (A_c V h / r^3 - v_c) / s_c.
// The written position, times the shoot's common scale k, as a measurement of sigma metres.
struct ScaledPriorCost {
  double w[3], inv_sigma;
  template <class T>
  bool operator()(const T* p, const T* k, T* r) const {
    for (int i = 0; i < 3; ++i) r[i] = (p[i] - k[0] * w[i]) * inv_sigma;
    return true;
  }
};

struct VignettedPaperCost {
  double x, y, r2, v[3], inv_s[3];
  template <class T>
  bool operator()(const T* p, const T* a, const T* vg, T* r) const {
    const T g = shading(p, x, y) * (1.0 + vg[0] * r2 + vg[1] * r2 * r2);
    for (int c = 0; c < 3; ++c) r[c] = (a[c] * g - v[c]) * inv_s[c];
    return true;
  }
};

}  // namespace

Vignetting fit_vignetting(const std::vector<std::vector<PaperSample>>& paper,
                          const std::vector<const Light*>& lights,
                          const std::vector<double>& sigma_m, double sample_height_m,
                          const Intrinsics& camera) {
  Vignetting vg;
  vg.cx = camera.cx, vg.cy = camera.cy;
  vg.half_diagonal = 0.5 * std::hypot(camera.width, camera.height);
  auto r2_of = [&](const PaperSample& sm) {
    const double du = sm.u - vg.cx, dv = sm.v - vg.cy;
    return (du * du + dv * dv) / (vg.half_diagonal * vg.half_diagonal);
  };
  // At most kPerPhoto points a photo, spread over its samples: V has two numbers, each lamp six.
  constexpr size_t kPerPhoto = 200, kMinPoints = 60, kMinPhotos = 3;
  std::vector<size_t> use;
  for (size_t i = 0; i < paper.size(); ++i) {
    if (i >= lights.size() || !lights[i] || paper[i].size() < kMinPoints) continue;
    use.push_back(i);
    for (const auto& sm : paper[i]) vg.r_max = std::max(vg.r_max, std::sqrt(r2_of(sm)));
  }
  if (use.size() < kMinPhotos || vg.r_max < 0.5) return vg;
  std::vector<std::array<double, 3>> p(use.size()), a(use.size());
  std::vector<double> prior_sigma(use.size());
  std::vector<Vec3> centre(use.size());
  for (size_t k = 0; k < use.size(); ++k) {
    const Light& l = *lights[use[k]];
    p[k] = {l.position.x, l.position.y, l.position.z};
    centre[k] = l.position;
    prior_sigma[k] = sigma_m[use[k]];
    intensity_at(paper[use[k]], p[k].data(), a[k].data());
  }
  double v[2] = {0, 0}, scale[1] = {1};
  ceres::Problem::Options po;
  std::unique_ptr<ceres::Problem> pb;
  for (int pass = 0; pass < 2; ++pass) {
    pb = std::make_unique<ceres::Problem>(po);
    vg.points = 0;
    for (size_t k = 0; k < use.size(); ++k) {
      const auto& samples = paper[use[k]];
      double med[3];
      channel_medians(samples, med);
      const size_t step = std::max<size_t>(1, samples.size() / kPerPhoto);
      for (size_t q = 0; q < samples.size(); q += step) {
        const auto& sm = samples[q];
        constexpr double kSpread = 0.02;  // the paper's shading about a lamp, relative
        auto* cost = new VignettedPaperCost{
            sm.x,
            sm.y,
            r2_of(sm),
            {sm.rgb[0], sm.rgb[1], sm.rgb[2]},
            {1 / (kSpread * med[0]), 1 / (kSpread * med[1]), 1 / (kSpread * med[2])}};
        pb->AddResidualBlock(new ceres::AutoDiffCostFunction<VignettedPaperCost, 3, 3, 3, 2>(cost),
                             new ceres::CauchyLoss(3.0), p[k].data(), a[k].data(), v);
        ++vg.points;
      }
      if (prior_sigma[k] < kPaperAloneSigmaM)
        pb->AddResidualBlock(
            new ceres::AutoDiffCostFunction<ScaledPriorCost, 3, 3, 1>(
                new ScaledPriorCost{{centre[k].x, centre[k].y, centre[k].z}, 1 / prior_sigma[k]}),
            nullptr, p[k].data(), scale);
      else
        pb->AddResidualBlock(new ceres::AutoDiffCostFunction<PriorCost, 3, 3>(new PriorCost{
                                 {centre[k].x, centre[k].y, centre[k].z}, 1 / prior_sigma[k]}),
                             nullptr, p[k].data());
      pb->SetParameterUpperBound(p[k].data(), 2, -sample_height_m - 0.01);
    }
    const ceres::Solver::Options so = lamp_solver(ceres::SPARSE_NORMAL_CHOLESKY);
    ceres::Solver::Summary summary;
    ceres::Solve(so, pb.get(), &summary);
    if (!summary.IsSolutionUsable() || !std::isfinite(v[0] + v[1])) return vg;
    // A lamp the paper puts far from where it is written: that position is no measurement of it.
    bool dropped = false;
    for (size_t k = 0; k < use.size(); ++k) {
      const Vec3 found{p[k][0], p[k][1], p[k][2]};
      if (prior_sigma[k] < kPaperAloneSigmaM &&
          length(found - centre[k] * scale[0]) > kDisagreeSigmas * prior_sigma[k]) {
        centre[k] = found, prior_sigma[k] = kPaperAloneSigmaM, dropped = true;
      }
    }
    if (!dropped) break;
  }
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance cov(co);
  double cv[4], ck = 0;
  const bool scaled = pb->HasParameterBlock(scale);
  std::vector<const double*> blocks{v};
  if (scaled) blocks.push_back(scale);
  if (!cov.Compute(blocks, pb.get()) || !cov.GetCovarianceBlock(v, v, cv) ||
      (scaled && !cov.GetCovarianceBlock(scale, scale, &ck)))
    return vg;
  if (scaled) {
    vg.scale = scale[0];
    vg.sigma_scale = std::sqrt(std::max(ck, 0.0));
    vg.scaled_lamps = 0;
    for (double sg : prior_sigma) vg.scaled_lamps += sg < kPaperAloneSigmaM;
  }
  vg.a1 = v[0], vg.a2 = v[1];
  vg.sigma_a1 = std::sqrt(std::max(cv[0], 0.0));
  vg.sigma_a2 = std::sqrt(std::max(cv[3], 0.0));
  vg.photos = use.size();
  vg.found = std::isfinite(vg.sigma_a1 + vg.sigma_a2);
  const double e2 = vg.r_max * vg.r_max, e4 = e2 * e2;
  vg.sigma_edge = std::sqrt(std::max(e4 * cv[0] + 2 * e2 * e4 * cv[1] + e4 * e4 * cv[3], 0.0));
  vg.applied = vg.found && std::abs(vg.at(vg.cx + vg.r_max * vg.half_diagonal, vg.cy) - 1) >
                               kVignettingSigmas * vg.sigma_edge;
  return vg;
}

void correct_vignetting(const Vignetting& v, std::vector<PaperSample>* samples) {
  for (auto& sm : *samples) {
    const float inv = static_cast<float>(1 / v.at(sm.u, sm.v));
    for (float& c : sm.rgb) c *= inv;
  }
}

}  // namespace aniso
