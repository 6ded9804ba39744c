#include "photo/import/import.h"

#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>

#include "core/angles.h"
#include "core/error.h"
#include "core/lens.h"
#include "core/progress.h"
#include "core/timer.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "photo/import/overlay.h"
#include "photo/lamps/lamps.h"
#include "photo/shoot/calibrate.h"
#include "photo/shoot/merge.h"
#include "photo/shoot/raw.h"

namespace aniso {

namespace {

using Clock = SteadyClock;

std::string photo_name(const Shoot& s, size_t i) {
  std::string n = "photos[" + std::to_string(i) + "] (" + s.photos[i].images[0].file;
  if (s.photos[i].images.size() > 1) n += " +" + std::to_string(s.photos[i].images.size() - 1);
  return n + ")";
}

// Pass 1 for one photo: merge, find the board, drop the corners the sample may hide.
struct Detected {
  std::vector<BoardCorner> corners, dropped;
  int markers = 0, width = 0, height = 0;
  size_t saturated = 0;
  MergedCrop crop;               // the merged image around the sample's estimated place
  OverlayImage overlay;          // the detection image, shrunk (overlays only)
  std::vector<RawInfo> raw;      // RAW images: camera and white balance
  std::vector<LampFound> lamps;  // per light of the photo, as found from the board's paper
  // The board's paper and the grey card as this photo read them (lamps found from a point lamp).
  std::vector<PaperSample> paper, card;
};

// Where the sample lies in a photo before the camera is known: its outline through the board's
// homography (no lens model), widened by 15 % and 24 pixels for what the lens bends.
void estimate_crop(const Shoot& s, const MergedPhoto& m, const std::vector<BoardCorner>& all,
                   MergedCrop* crop) {
  std::array<double, 9> H;
  if (!board_homography(all, s.board, &H)) return;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const auto& p : s.polygon) {
    const double w = H[6] * p[0] + H[7] * p[1] + H[8];
    if (!(w > 0)) return;
    const double x = (H[0] * p[0] + H[1] * p[1] + H[2]) / w,
                 y = (H[3] * p[0] + H[4] * p[1] + H[5]) / w;
    x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  }
  const double pad = 0.15 * std::max(x1 - x0, y1 - y0) + 24;
  if (!(x1 - x0 < 4.0 * m.rgb.width && y1 - y0 < 4.0 * m.rgb.height)) return;
  *crop = crop_merged(m, static_cast<int>(x0 - pad), static_cast<int>(y0 - pad),
                      static_cast<int>(x1 + pad), static_cast<int>(y1 + pad));
}

// The paper's reflectance per channel: the shoot's, else the assumed one (photo/lamps/lamps.h).
RGB paper_rho(const Shoot& s) {
  return s.paper_given()
             ? s.paper_reflectance
             : RGB{kAssumedPaperReflectance, kAssumedPaperReflectance, kAssumedPaperReflectance};
}

// How well light k of a photo was measured (a photo built in code may not say).
double sigma_of(const ShootPhoto& ph, size_t k) {
  return k < ph.position_sigma_m.size() ? ph.position_sigma_m[k] : kDefaultLampSigmaM;
}

// The photo's lamps from the board's paper (and the grey card's reading under them): one point
// lamp alone (photo/lamps/lamps.h find_lamp), or several together, whose shading on the paper is
// their sum (find_lamps_together).
std::vector<LampFound> find_lamps(const Shoot& s, size_t i, const std::vector<PaperSample>& paper,
                                  const std::vector<PaperSample>& card) {
  const ShootPhoto& ph = s.photos[i];
  std::vector<LampFound> out;
  if (ph.lights.size() == 1) {
    // The written position as if x or y were measured from the board's far edge.
    const double W = s.board.squares_x * s.board.square_m, H = s.board.squares_y * s.board.square_m;
    const Vec3 w = ph.lights[0].position;
    out.push_back(find_lamp(paper, ph.lights[0], sigma_of(ph, 0), paper_rho(s), s.height_m,
                            {{W - w.x, w.y, w.z}, {w.x, H - w.y, w.z}}));
  } else {
    std::vector<double> sigma;
    for (size_t k = 0; k < ph.lights.size(); ++k) sigma.push_back(sigma_of(ph, k));
    out = find_lamps_together(paper, ph.lights, sigma, paper_rho(s), s.height_m);
  }
  if (s.reference_given()) read_card(card, &out);
  return out;
}

// The merged regions around the samples kept between the passes while they fit in their budget;
// a photo whose region does not is decoded again for its view.
class CropKeeper {
 public:
  explicit CropKeeper(double budget_mb) : left_(static_cast<long long>(budget_mb * 1e6)) {}
  bool keep(const MergedCrop& c) {
    const long long bytes = static_cast<long long>(c.rgb.px.size() * 4 + c.saturated.size());
    if (left_.fetch_sub(bytes) >= bytes) return true;
    left_.fetch_add(bytes);
    return false;
  }

 private:
  std::atomic<long long> left_;
};

Detected detect_photo(const Shoot& s, size_t i, const ImportOptions& o, const PaperPoints& paper,
                      CropKeeper& crops) {
  const MergedPhoto m = merge_bracket(s, i, o.raw_develop);
  Detected d;
  d.width = m.rgb.width;
  d.height = m.rgb.height;
  d.saturated = m.saturated_pixels;
  d.raw = m.raw;
  const auto obj = board_corners_m(s.board);
  const std::vector<BoardCorner> all =
      detect_board(m.grey.data(), m.rgb.width, m.rgb.height, s.board, &d.markers);
  for (const auto& c : all) {
    const double x = obj.at(c.id)[0], y = obj.at(c.id)[1];
    const bool near =
        inside_polygon(s.polygon, x, y) || distance_to_outline(s.polygon, x, y) < o.sample_margin_m;
    (near ? d.dropped : d.corners).push_back(c);
  }
  estimate_crop(s, m, all, &d.crop);
  if (!crops.keep(d.crop)) d.crop = MergedCrop{};
  if (o.find_lamps) {
    d.paper = paper_samples(s.board, paper, d.corners, m.rgb, m.saturated);
    d.card = card_samples(s.board, s.reference.polygon, d.corners, m.rgb, m.saturated);
    d.lamps = find_lamps(s, i, d.paper, d.card);
  }
  if (o.overlays) d.overlay = overlay_image(m.grey, m.rgb.width, m.rgb.height);
  return d;
}

// No photo shows a marker of the stated dictionary: say which dictionary does, if any.
[[noreturn]] void no_markers(const Shoot& s) {
  const MergedPhoto m = merge_bracket(s, 0);
  std::string found;
  for (const auto& name : aruco_dictionary_names()) {
    BoardSpec b = s.board;
    b.dictionary = name;
    int markers = 0;
    try {
      detect_board(m.grey.data(), m.rgb.width, m.rgb.height, b, &markers);
    } catch (const Error&) {
      continue;  // this board size does not fit that dictionary
    }
    if (markers >= 4)
      found += (found.empty() ? "" : ", ") + name + " (" + std::to_string(markers) + ")";
  }
  throw Error(s.file + ": board.dictionary: no " + s.board.dictionary +
              " marker was found in any photo. " +
              (found.empty() ? "No other dictionary finds markers either: is the board in the "
                               "photos, in focus and lit?"
                             : "The first photo shows markers of " + found +
                                   ": was the board printed with that dictionary?"));
}

// Tilt of the board against the optical axis, degrees, and the direction it tilts toward.
double tilt_deg(const Mat4& cfb, double* azimuth) {
  *azimuth = std::atan2(cfb(1, 2), cfb(0, 2));
  return rad_to_deg(std::acos(std::min(1.0, std::abs(cfb(2, 2)))));
}

constexpr double kMinTilt = 10;  // degrees: a photo that sees the board tilted at least this

// How the tilted photos tilt the board in their own frames: 1 when all about one image axis (a
// camera held upright while walking round the board), less the more the directions spread.
double tilt_axis_spread(const std::vector<Mat4>& poses, int* tilted) {
  double cx = 0, cy = 0;
  *tilted = 0;
  for (const auto& p : poses) {
    double az;
    if (tilt_deg(p, &az) < kMinTilt) continue;
    ++*tilted;
    cx += std::cos(az);
    cy += std::sin(az);
  }
  return *tilted ? std::hypot(cx, cy) / *tilted : 1;
}

// Calibration needs the board seen tilted, from places apart: refused only where the photos
// cannot calibrate a camera at all (too few tilted photos, or every photo from one place).
void check_tilt(const Shoot& s, const std::vector<Mat4>& poses) {
  int tilted = 0;
  tilt_axis_spread(poses, &tilted);
  double apart = 0;  // the largest distance between two of the cameras, metres
  for (size_t a = 0; a < poses.size(); ++a)
    for (size_t b = a + 1; b < poses.size(); ++b)
      apart = std::max(apart, length(rigid_inverse(poses[a]).translation() -
                                     rigid_inverse(poses[b]).translation()));
  constexpr double kOnePlaceM = 0.05;
  if (tilted >= 3 && apart >= kOnePlaceM) return;
  char where[160];
  std::snprintf(where, sizeof where, "%d of %zu photos see the board tilted %d degrees or more",
                tilted, poses.size(), static_cast<int>(kMinTilt));
  throw Error(s.file + ": too little tilt to calibrate the camera: " + where +
              (apart < kOnePlaceM ? ", and all were taken from one place (the cameras within " +
                                        std::to_string(static_cast<int>(apart * 100 + 0.5)) + " cm)"
                                  : std::string()) +
              ". Walk round the board with the camera 40-70 degrees above it (at least 3 photos "
              "from different sides), and turn the camera 90 degrees for a few of them; or give "
              "the camera's intrinsics as \"camera\" in the shoot");
}

// The camera (given, or calibrated from the photos with enough corners; photos that reproject
// poorly are left out and the calibration repeated once without them) and every usable photo's
// pose and reprojection error.
void solve_cameras(const Shoot& s, const std::vector<Detected>& det, const ImportOptions& o,
                   ImportResult* r) {
  std::vector<size_t> use;
  for (size_t i = 0; i < det.size(); ++i) {
    ImportedPhoto& p = r->photos[i];
    if (det[i].corners.size() >= static_cast<size_t>(o.min_corners)) {
      use.push_back(i);
      continue;
    }
    p.reason = "board not found: " + std::to_string(det[i].markers) + " markers, " +
               std::to_string(det[i].corners.size()) + " corners off the sample (at least " +
               std::to_string(o.min_corners) + " needed)";
  }
  std::vector<Mat4> poses(det.size());
  if (s.camera_given) {
    r->camera = s.camera;
  } else {
    constexpr size_t kMinPhotos = 4;
    std::vector<double> first_rms;  // each calibrated photo's RMS in the first round
    // The calibration's cost grows as the cube of its photos: at most
    // o.calibrate_on, spread evenly over the shoot's order (a walk round the board); the others
    // are posed against the camera it gives.
    const size_t most = static_cast<size_t>(std::max(o.calibrate_on, static_cast<int>(kMinPhotos)));
    if (use.size() > most) {
      std::vector<size_t> spread;
      for (size_t k = 0; k < most; ++k) spread.push_back(use[k * use.size() / most]);
      use = spread;
    }
    // At most three calibrations (OpenCV's, each one call with no progress of its own): the
    // first, again without poor photos, again holding what the photos leave undetermined.
    Progress bar("import: calibrating the camera", 3, o.progress);
    int calibrations = 0;
    for (int round = 0; round < 2; ++round) {
      if (use.size() < kMinPhotos) {
        // Say what was found: markers that fit no board of this layout, or photos whose RMS is
        // over --max-rms; more photos is the advice only where the photos are what is missing.
        size_t with_markers = 0;
        std::vector<int> markers;
        for (const auto& d : det)
          if (d.markers > 0) ++with_markers, markers.push_back(d.markers);
        std::string why;
        if (round == 1) {
          std::sort(first_rms.begin(), first_rms.end());
          char buf[256];
          const double median = first_rms[first_rms.size() / 2];
          // Pixels of error, not fractions: the corners fit no board of the layout given.
          constexpr double kLayoutWrongPx = 5;
          std::snprintf(buf, sizeof buf,
                        "the board was found in %zu photos, but only %zu reproject within "
                        "--max-rms %.2f px (their RMS: %.2f to %.2f px, median %.2f)",
                        first_rms.size(), use.size(), o.max_rms_px, first_rms.front(),
                        first_rms.back(), median);
          why = buf;
          why += median > kLayoutWrongPx
                     ? ": corners that far off fit no " + std::to_string(s.board.squares_x) + "x" +
                           std::to_string(s.board.squares_y) +
                           " board of these sizes; check board.squares, board.square_m and "
                           "board.marker_m against the printed board"
                     : ": raise --max-rms, or check the photos' focus and board.square_m";
        } else if (with_markers >= kMinPhotos) {
          std::nth_element(markers.begin(), markers.begin() + markers.size() / 2, markers.end());
          why = std::to_string(with_markers) + " of " + std::to_string(det.size()) +
                " photos show markers of " + s.board.dictionary + " (median " +
                std::to_string(markers[markers.size() / 2]) + "), but in " +
                std::to_string(det.size() - use.size()) + " of them fewer than " +
                std::to_string(o.min_corners) + " corners of a " +
                std::to_string(s.board.squares_x) + "x" + std::to_string(s.board.squares_y) +
                " board were found off the sample: check board.squares (and board.square_m, "
                "board.marker_m) against the printed board";
        } else {
          why = "the board was found in " + std::to_string(use.size()) + " of " +
                std::to_string(det.size()) + " photos (at least " + std::to_string(kMinPhotos) +
                " needed; 10-20 photos from different sides, the board tilted 15-45 degrees, "
                "calibrate well)";
        }
        throw Error(s.file + ": too few photos to calibrate the camera: " + why +
                    "; or give the camera's intrinsics as \"camera\" in the shoot");
      }
      std::vector<std::vector<BoardCorner>> views;
      for (size_t i : use) views.push_back(det[i].corners);
      const Calibration cal =
          calibrate_charuco(s.board, views, det[use[0]].width, det[use[0]].height);
      bar.advance(), ++calibrations;
      r->camera = cal.camera;
      r->calibration_rms_px = cal.rms_px;
      r->sigma = cal.sigma;
      std::vector<size_t> keep;
      if (round == 0) first_rms = cal.view_rms_px;
      for (size_t k = 0; k < use.size(); ++k) {
        poses[use[k]] = cal.camera_from_board[k];
        if (cal.view_rms_px[k] <= o.max_rms_px) keep.push_back(use[k]);
      }
      if (keep.size() == use.size()) break;
      use = keep;  // calibrate again without the poor photos (they are judged again below)
    }
    std::vector<Mat4> used_poses;
    for (size_t i : use) used_poses.push_back(poses[i]);
    check_tilt(s, used_poses);
    // What these photos leave undetermined is held and said: fx apart from fy where every photo
    // tilts the board about one image axis; the principal point where it is poorly seen.
    CalibrationHolds holds;
    int tilted = 0;
    const double spread = tilt_axis_spread(used_poses, &tilted);
    constexpr double kOneAxis = 0.95, kCentreSigma = 0.02;
    if (spread >= kOneAxis) {
      holds.square_pixels = true;
      char why[200];
      std::snprintf(why, sizeof why,
                    "fx = fy (square pixels): all %d tilted photos tilt the board about one image "
                    "axis (spread %.3f), which leaves fx and fy apart undetermined",
                    tilted, 1 - spread);
      r->held.push_back(why);
    }
    if (r->sigma[2] > kCentreSigma * det[use[0]].width ||
        r->sigma[3] > kCentreSigma * det[use[0]].height) {
      holds.centre = true;
      char why[200];
      std::snprintf(why, sizeof why,
                    "the principal point at the image centre: the photos put it at +- %.1f, %.1f "
                    "px (over %.0f %% of the image)",
                    r->sigma[2], r->sigma[3], 100 * kCentreSigma);
      r->held.push_back(why);
    }
    if (holds.square_pixels || holds.centre) {
      std::vector<std::vector<BoardCorner>> views;
      for (size_t i : use) views.push_back(det[i].corners);
      const Calibration cal =
          calibrate_charuco(s.board, views, det[use[0]].width, det[use[0]].height, holds);
      bar.advance(), ++calibrations;
      r->camera = cal.camera;
      r->calibration_rms_px = cal.rms_px;
      r->sigma = cal.sigma;
      if (holds.square_pixels) r->sigma[0] = r->sigma[1] = std::max(r->sigma[0], r->sigma[1]);
      for (size_t k = 0; k < use.size(); ++k) poses[use[k]] = cal.camera_from_board[k];
    }
    bar.advance(static_cast<size_t>(3 - calibrations));  // done, whichever it took
    r->calibrated = true;
    r->calibrated_on = use.size();
  }
  for (size_t i = 0; i < det.size(); ++i) {
    ImportedPhoto& p = r->photos[i];
    if (det[i].corners.size() < static_cast<size_t>(o.min_corners)) continue;
    if (det[i].width != r->camera.width || det[i].height != r->camera.height) {
      p.reason = "photo is " + std::to_string(det[i].width) + "x" + std::to_string(det[i].height) +
                 ", the camera " + std::to_string(r->camera.width) + "x" +
                 std::to_string(r->camera.height);
      continue;
    }
    if ((s.camera_given || std::find(use.begin(), use.end(), i) == use.end()) &&
        !board_pose(s.board, det[i].corners, r->camera, &poses[i])) {
      p.reason = "no board pose found";
      continue;
    }
    double az;
    p.rms_px = reprojection_rms(s.board, det[i].corners, r->camera, poses[i]);
    p.tilt_deg = tilt_deg(poses[i], &az);
    p.world_from_camera = rigid_inverse(poses[i]);
    p.accepted = p.rms_px <= o.max_rms_px;
    if (!p.accepted) p.reason = "reprojection RMS " + std::to_string(p.rms_px) + " px > --max-rms";
  }
}

// Board point (x, y, -height) -> pixel through the pose and lens; false behind the camera.
bool to_pixel(const Intrinsics& k, const Mat4& cfb, double x, double y, double z,
              std::array<double, 2>* px) {
  const Vec3 pc = cfb.point({x, y, z});
  if (!(pc.z > 1e-6)) return false;
  project_point(k, pc, &(*px)[0], &(*px)[1]);
  return std::isfinite((*px)[0]) && std::isfinite((*px)[1]);
}

// The sample's outline in a photo, each edge in 16 steps (the lens bends straight edges).
OverlayMarks::Points sample_outline(const Shoot& s, const Intrinsics& k, const Mat4& cfb) {
  OverlayMarks::Points out;
  for (size_t i = 0; i < s.polygon.size(); ++i) {
    const auto& a = s.polygon[i];
    const auto& b = s.polygon[(i + 1) % s.polygon.size()];
    for (int t = 0; t < 16; ++t) {
      std::array<double, 2> px;
      const double f = t / 16.0;
      if (to_pixel(k, cfb, a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), -s.height_m, &px))
        out.push_back(px);
    }
  }
  return out;
}

// One view's crop around the sample and its per-pixel geometry on the plane z = -height_m.
struct ViewGeometry {
  int x0 = 0, y0 = 0, w = 0, h = 0;
  Image P, N, U, uv;
  std::vector<uint8_t> mask;
  size_t pixels = 0;
};
// The pixels around the sample's outline (3 pixels spare); false if it is not in the photo.
bool view_box(const Intrinsics& k, const OverlayMarks::Points& outline, ViewGeometry* g) {
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  for (const auto& p : outline) {
    xmin = std::min(xmin, p[0]), xmax = std::max(xmax, p[0]);
    ymin = std::min(ymin, p[1]), ymax = std::max(ymax, p[1]);
  }
  g->x0 = std::max(0, static_cast<int>(std::floor(xmin)) - 3);
  g->y0 = std::max(0, static_cast<int>(std::floor(ymin)) - 3);
  const int x1 = std::min(k.width - 1, static_cast<int>(std::ceil(xmax)) + 3);
  const int y1 = std::min(k.height - 1, static_cast<int>(std::ceil(ymax)) + 3);
  if (outline.empty() || x1 <= g->x0 || y1 <= g->y0) return false;
  g->w = x1 - g->x0 + 1;
  g->h = y1 - g->y0 + 1;
  return true;
}

// Fills the view's buffers for the box already in g; `mc` (holding the box) says which pixels are
// saturated.
bool view_geometry(const Shoot& s, const Intrinsics& k, const Mat4& wfc, const MergedCrop& mc,
                   ViewGeometry* g) {
  // Board-plane points of the crop's pixels plus one row and column (for the footprint).
  std::vector<Vec3> P(static_cast<size_t>(g->w + 1) * (g->h + 1), Vec3(NAN, NAN, NAN));
  for (int y = 0; y <= g->h; ++y)
    for (int x = 0; x <= g->w; ++x)
      pixel_on_plane(k, wfc, g->x0 + x, g->y0 + y, -s.height_m,
                     &P[static_cast<size_t>(y) * (g->w + 1) + x]);
  double bx0 = INFINITY, bx1 = -INFINITY, by0 = INFINITY, by1 = -INFINITY;
  for (const auto& p : s.polygon)
    bx0 = std::min(bx0, p[0]), bx1 = std::max(bx1, p[0]), by0 = std::min(by0, p[1]),
    by1 = std::max(by1, p[1]);
  g->P = Image(g->w, g->h, 3);
  g->N = Image(g->w, g->h, 3);
  g->U = Image(g->w, g->h, 3);
  g->uv = Image(g->w, g->h, 2);
  g->mask.assign(static_cast<size_t>(g->w) * g->h, 0);
  for (int y = 0; y < g->h; ++y)
    for (int x = 0; x < g->w; ++x) {
      const Vec3& p = P[static_cast<size_t>(y) * (g->w + 1) + x];
      const Vec3& px = P[static_cast<size_t>(y) * (g->w + 1) + x + 1];
      const Vec3& py = P[static_cast<size_t>(y + 1) * (g->w + 1) + x];
      g->N.at(x, y, 2) = -1;
      g->U.at(x, y, 0) = static_cast<float>(s.tangent[0]);
      g->U.at(x, y, 1) = static_cast<float>(s.tangent[1]);
      if (!std::isfinite(p.x) || !std::isfinite(px.x) || !std::isfinite(py.x)) continue;
      for (int c = 0; c < 3; ++c) g->P.at(x, y, c) = static_cast<float>(p[c]);
      g->uv.at(x, y, 0) = static_cast<float>((p.x - bx0) / (bx1 - bx0));
      g->uv.at(x, y, 1) = static_cast<float>((p.y - by0) / (by1 - by0));
      // Inside the outline by at least the pixel's footprint: the border pixels mix in the board.
      const double foot = std::max(length(px - p), length(py - p));
      const bool in =
          inside_polygon(s.polygon, p.x, p.y) && distance_to_outline(s.polygon, p.x, p.y) >= foot &&
          !mc.saturated[static_cast<size_t>(g->y0 - mc.y0 + y) * mc.w + g->x0 - mc.x0 + x];
      g->mask[static_cast<size_t>(y) * g->w + x] = in;
      g->pixels += in;
    }
  return g->pixels > 0;
}

Image crop(const Image& im, int x0, int y0, int w, int h) {
  Image out(w, h, im.channels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < im.channels; ++c) out.at(x, y, c) = im.at(x0 + x, y0 + y, c);
  return out;
}

// What the overlay shows of a photo before its view is written: corners found and dropped, and,
// with a pose, the board and the sample's outline through it.
OverlayMarks photo_marks(const Shoot& s, size_t i, const Detected& det, const Intrinsics& k,
                         const ImportedPhoto& p) {
  OverlayMarks marks;
  for (const auto& c : det.corners) marks.found.push_back({c.x, c.y});
  for (const auto& c : det.dropped) marks.dropped.push_back({c.x, c.y});
  marks.label =
      "photo " + std::to_string(i) + ": " + std::to_string(det.corners.size()) + " corners";
  if (p.rms_px < 0) return marks;
  const Mat4 cfb = rigid_inverse(p.world_from_camera);
  for (const auto& c : board_corners_m(s.board)) {
    std::array<double, 2> px;
    if (to_pixel(k, cfb, c[0], c[1], 0, &px)) marks.reprojected.push_back(px);
  }
  marks.outline = sample_outline(s, k, cfb);
  char buf[64];
  std::snprintf(buf, sizeof buf, ", RMS %.2f px", p.rms_px);
  marks.label += buf;
  return marks;
}

// The view's files: its merged image cropped to the sample, position, normal, tangent, uv, mask.
void write_view(const Shoot& s, size_t i, const ViewGeometry& g, const MergedCrop& mc,
                const Intrinsics& k, const ImportedPhoto& p, const Vignetting& vignetting,
                const std::string& dir, const std::string& out_dir, ExrCompression c,
                ViewSpec* view) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "%03zu", i);
  view->image = std::string("images/") + stem + ".exr";
  view->world_from_camera = p.world_from_camera;
  view->lights = s.photos[i].lights;
  for (size_t k = 0; k < view->lights.size(); ++k) {
    Light& l = view->lights[k];
    if (l.type == Light::Type::kDirectional) continue;
    const double written = sigma_of(s.photos[i], k);
    l.position_sigma_m = {written, written, written};
    if (k < p.lamps.size() && p.lamps[k].solved) {
      const LampFound& f = p.lamps[k];
      l.position = f.found;
      l.intensity = f.found_intensity;
      l.position_sigma_m = {f.sigma_m[0], f.sigma_m[1], f.sigma_m[2]};
    }
  }
  view->camera = k;
  view->camera.width = g.w;
  view->camera.height = g.h;
  view->camera.cx -= g.x0;
  view->camera.cy -= g.y0;
  GeometrySpec& gs = view->geometry;
  const std::string base = std::string("geometry/") + stem;
  gs = {base + "_P.exr",
        base + "_N.exr",
        base + "_U.exr",
        base + "_mask.png",
        base + "_uv.exr",
        "",
        "",
        ""};
  Image img = crop(mc.rgb, g.x0 - mc.x0, g.y0 - mc.y0, g.w, g.h);
  if (vignetting.applied)  // what the scene sent: the image over the lens's V at each pixel
    for (int y = 0; y < g.h; ++y)
      for (int x = 0; x < g.w; ++x) {
        const float inv = static_cast<float>(1 / vignetting.at(g.x0 + x, g.y0 + y));
        for (int c = 0; c < 3; ++c) img.at(x, y, c) *= inv;
      }
  write_exr(join_path(dir, view->image), img, c);
  write_exr(join_path(dir, gs.position), g.P, c);
  write_exr(join_path(dir, gs.normal), g.N, c);
  write_exr(join_path(dir, gs.tangent), g.U, c);
  write_exr(join_path(dir, gs.uv), g.uv, c);
  Image mask(g.w, g.h, 1);
  for (size_t q = 0; q < g.mask.size(); ++q) mask.px[q] = g.mask[q];
  write_png(join_path(dir, gs.mask), mask, 8);
  for (const auto& im : s.photos[i].images)
    view->source.push_back(relative_to(join_path(s.dir, im.file), out_dir));
}

// At most n photos decoded at once (the merges memory_mb allows) while more views than that are
// written at once.
class DecodeGate {
 public:
  explicit DecodeGate(int n) : free_(n) {}
  template <class F>
  auto run(F&& f) {
    {
      std::unique_lock<std::mutex> lock(m_);
      cv_.wait(lock, [&] { return free_ > 0; });
      --free_;
    }
    struct Leave {
      DecodeGate* g;
      ~Leave() {
        {
          std::lock_guard<std::mutex> lock(g->m_);
          ++g->free_;
        }
        g->cv_.notify_one();
      }
    } leave{this};
    return f();
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  int free_;
};

// Pass 2 for one photo: its view (if accepted) from the crop kept by pass 1 (the photo is decoded
// again, through `gate`, where the crop was not kept or the sample lies outside it), and its
// overlay.
void write_photo(const Shoot& s, size_t i, Detected& det, const std::string& dir,
                 const std::string& out_dir, const ImportOptions& o, DecodeGate& gate,
                 ImportResult* r, ViewSpec* view) {
  ImportedPhoto& p = r->photos[i];
  OverlayMarks marks = photo_marks(s, i, det, r->camera, p);
  ViewGeometry g;
  if (p.accepted && view_box(r->camera, marks.outline, &g)) {
    if (!det.crop.contains(g.x0, g.y0, g.w, g.h)) {
      det.crop = gate.run([&] {
        return crop_merged(merge_bracket(s, i, o.raw_develop), g.x0, g.y0, g.x0 + g.w - 1,
                           g.y0 + g.h - 1);
      });
      p.decoded_twice = true;
    }
    if (!view_geometry(s, r->camera, p.world_from_camera, det.crop, &g)) p.accepted = false;
  } else {
    p.accepted = false;
  }
  if (p.accepted) {
    p.sample_pixels = g.pixels;
    write_view(s, i, g, det.crop, r->camera, p, r->vignetting, dir, out_dir, o.compression, view);
    marks.mask = g.mask;
    marks.mask_x0 = g.x0, marks.mask_y0 = g.y0, marks.mask_w = g.w, marks.mask_h = g.h;
  } else {
    if (p.reason.empty())
      p.reason = "the sample is not in view (or every sample pixel is saturated)";
    marks.label += ": LEFT OUT, " + p.reason;
  }
  det.crop = MergedCrop{};
  if (!o.overlays) return;
  char name[32];
  std::snprintf(name, sizeof name, "overlays/%03zu.png", i);
  write_overlay(join_path(dir, name), det.overlay, marks);
  det.overlay = OverlayImage{};
}

// What the lamps found from the paper say about the shoot as written: a lamp far from where it
// was written (kDisagreeSigmas beyond what the paper alone and position_sigma_m allow), and where
// every such lamp sits where the written one would be measured from the board's other edge, that.
std::vector<std::string> lamp_warnings(const Shoot& s, const ImportResult& r) {
  std::vector<std::string> out;
  int far = 0, mirrored_x = 0, mirrored_y = 0;
  std::string first;
  for (size_t i = 0; i < r.photos.size(); ++i)
    for (size_t k = 0; k < r.photos[i].lamps.size(); ++k) {
      const LampFound& l = r.photos[i].lamps[k];
      if (!l.solved || l.disagreement < kDisagreeSigmas) continue;
      ++far;
      const auto& alt = l.agrees_with;
      mirrored_x += std::find(alt.begin(), alt.end(), 0) != alt.end();
      mirrored_y += std::find(alt.begin(), alt.end(), 1) != alt.end();
      if (first.empty()) {
        char buf[400];
        std::snprintf(buf, sizeof buf,
                      "photos[%zu].lights[%zu].position: the board's paper puts the lamp at "
                      "(%.3f, %.3f, %.3f) m, %.0f mm from where it is written (%.1f sigma, with "
                      "position_sigma_m %.3f m)",
                      i, k, l.found.x, l.found.y, l.found.z, 1000 * length(l.found - l.written),
                      l.disagreement, l.prior_sigma_m);
        first = buf;
      }
    }
  // A wrong board.square_m scales the whole board frame, so the paper puts every lamp farther
  // from (or nearer to) the board's corner than the tape did, by one factor: the paper-alone
  // positions against the written ones.
  double aw = 0, ww = 0;
  size_t lamps = 0;
  for (const auto& p : r.photos)
    for (const LampFound& l : p.lamps)
      if (l.solved) aw += dot(l.alone, l.written), ww += dot(l.written, l.written), ++lamps;
  if (lamps >= 3 && ww > 0) {
    double k = aw / ww;
    double rr = 0;
    for (const auto& p : r.photos)
      for (const LampFound& l : p.lamps)
        if (l.solved) rr += dot(l.alone - l.written * k, l.alone - l.written * k);
    double sigma_k = std::sqrt(rr / (3.0 * lamps - 1) / ww);
    // With the lens's vignetting fitted, the common scale fitted with it (the paper alone lets
    // each lamp take up part of the vignetting).
    if (r.vignetting.found && r.vignetting.scaled_lamps >= 3)
      k = r.vignetting.scale, sigma_k = r.vignetting.sigma_scale, lamps = r.vignetting.scaled_lamps;
    constexpr double kScaleOff = 0.03;  // beyond a tape's and a printer's error
    if (std::abs(k - 1) > std::max(kScaleOff, 4 * sigma_k)) {
      char buf[500];
      std::snprintf(buf, sizeof buf,
                    "board.square_m: the board's paper puts every lamp %.3f times as far from the "
                    "board's corner as written (+- %.3f over %zu lamps): the board frame is "
                    "scaled by square_m, so the printed squares are probably %.4f m, not %.4f m "
                    "(measure one square of the print), or the lamps were measured in another "
                    "unit",
                    k, sigma_k, lamps, s.board.square_m / k, s.board.square_m);
      out.push_back(buf);
      return out;
    }
  }
  if (far == 0) return out;
  std::string msg = first;
  if (far > 1) msg += " (and " + std::to_string(far - 1) + " more lamps as far off)";
  if (mirrored_x == far)
    msg +=
        "; every such lamp is where x measured from the board's right edge would put it: "
        "board x runs right from the top-left corner as printed";
  else if (mirrored_y == far)
    msg +=
        "; every such lamp is where y measured from the board's bottom edge would put it: "
        "board y runs down from the top-left corner as printed";
  else
    msg +=
        ": the paper's position is used; check the tape measure's origin and units, or raise "
        "position_sigma_m";
  out.push_back(msg);
  return out;
}

}  // namespace

// How many photos may be merged at once within o.memory_mb, from the photos' headers (nothing
// decoded). A photo being merged holds, per pixel, its merged RGB (12 bytes), clipped mask and
// detection image (1 each) and the board detector's working images (kDetectBytes), plus 12 bytes
// for each image of its bracket that is read whole as floats (EXR, TIFF) and what each RAW file's
// developer holds (photo/shoot/raw.h raw_header); PNG and JPEG stream row by row. Every photo
// keeps its overlay between the passes; what the budget leaves beside the merges is
// r->crop_budget_mb, for the merged regions around the samples (CropKeeper). Throws, saying why,
// where even one photo at a time does not fit.
int merge_threads(const Shoot& s, const ImportOptions& o, ImportResult* r) {
  constexpr double kDetectBytes = 6;
  double overlays = 0, largest = 0;
  for (size_t i = 0; i < s.photos.size(); ++i) {
    double bytes = 0, pixels = 0, develop = 0;
    int w = 0, h = 0;
    for (const auto& im : s.photos[i].images) {
      const std::string path = join_path(s.dir, im.file);
      const std::string ext = lower_ext(path);
      if (is_raw_photo(path)) {  // what its developer holds; one develops at a time
        const RawHeader rh = raw_header(path, o.raw_develop);
        w = rh.width, h = rh.height;
        bytes += rh.held_bytes * w * h;
        develop = std::max(develop, rh.developing_bytes * w * h);
      } else {
        image_dimensions(path, &w, &h);
        if (ext == ".exr" || ext == ".tif" || ext == ".tiff") bytes += 12.0 * w * h;  // float RGB
      }
      pixels = std::max(pixels, double(w) * h);
    }
    bytes += develop + pixels * (12 + 1 + 1 + kDetectBytes);
    const int shrink = overlay_shrink(w, h);
    overlays += o.overlays ? pixels / (shrink * shrink) : 0;
    largest = std::max(largest, bytes);
  }
  const double budget = o.memory_mb * 1e6;
  const int cores = tbb::info::default_concurrency();
  const int fit = static_cast<int>(std::floor((budget - overlays) / largest));
  char buf[512];
  if (fit < 1) {
    std::snprintf(buf, sizeof buf,
                  ": the shoot needs at least %.0f MB (%zu photos keep %.0f MB of overlays "
                  "between the passes, and merging the largest bracket takes %.0f MB), over "
                  "--memory %.0f MB; raise --memory, import without overlays (--no-overlays), or "
                  "fewer photos or exposures at a time",
                  (overlays + largest) / 1e6, s.photos.size(), overlays / 1e6, largest / 1e6,
                  o.memory_mb);
    throw Error(s.file + buf);
  }
  r->merge_threads = std::min(fit, cores);
  r->crop_budget_mb = (budget - overlays - r->merge_threads * largest) / 1e6;
  r->memory_estimate_mb = (overlays + r->merge_threads * largest) / 1e6;
  return r->merge_threads;
}

// The lens's vignetting from every photo's paper and written lamp (photo/lamps/lamps.h
// fit_vignetting); then each photo's lamp is found again from its paper and card read through it.
void find_vignetting(const Shoot& s, std::vector<Detected>& det, ImportResult* r) {
  std::vector<std::vector<PaperSample>> paper(det.size());
  std::vector<const Light*> lights(det.size(), nullptr);
  std::vector<double> sigma(det.size(), kDefaultLampSigmaM);
  for (size_t i = 0; i < det.size(); ++i) {
    paper[i] = std::move(det[i].paper);  // read as it is by the fit, through V after it
    const ShootPhoto& ph = s.photos[i];
    if (ph.lights.size() == 1 && inverse_square_point(ph.lights[0])) lights[i] = &ph.lights[0];
    sigma[i] = sigma_of(ph, 0);
  }
  const Vignetting v = fit_vignetting(paper, lights, sigma, s.height_m, r->camera);
  r->vignetting = v;
  if (!v.applied) return;
  tbb::parallel_for(size_t(0), det.size(), [&](size_t i) {
    if (paper[i].empty()) return;
    std::vector<PaperSample> p = paper[i], c = det[i].card;
    correct_vignetting(v, &p);
    correct_vignetting(v, &c);
    det[i].lamps = find_lamps(s, i, p, c);
  });
}

// The grey card makes the found lamps' intensities absolute: the paper's reflectance from the card
// (photo/lamps/lamps.h paper_from_card) in place of the shoot's or the assumed one. A card seen in
// no photo, or one that contradicts board.paper_reflectance, is said.
void scale_by_card(const Shoot& s, ImportResult* r) {
  std::vector<const LampFound*> lamps;
  for (const auto& p : r->photos)
    for (const auto& l : p.lamps) lamps.push_back(&l);
  r->card = paper_from_card(lamps, s.reference.reflectance);
  if (!r->card.found) {
    r->warnings.push_back(
        "reference: the grey card was read in no photo (too little of it in view, clipped, or "
        "unevenly lit; it needs " +
        std::to_string(kMinCardPoints) +
        " points 3 mm inside its edge, under a found lamp): the intensities stay relative to the "
        "paper");
    return;
  }
  for (auto& p : r->photos)
    for (auto& l : p.lamps)
      if (l.solved)
        for (int c = 0; c < 3; ++c)
          l.found_intensity[c] = l.paper_amplitude[c] * M_PI / r->card.paper[c];
  if (s.paper_given()) {
    const double given = s.paper_reflectance[1], found = r->card.paper[1];
    if (std::abs(given - found) > std::max(3 * r->card.sigma[1], 0.05 * found)) {
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    "board.paper_reflectance: the grey card (reference, reflectance %.3f) puts the "
                    "paper at %.3f +- %.3f (green), not %.3f as written; the card's is used (check "
                    "the card's reflectance, or drop board.paper_reflectance)",
                    s.reference.reflectance[1], found, r->card.sigma[1], given);
      r->warnings.push_back(buf);
    }
  }
}

ImportResult import_shoot(const Shoot& s, const std::string& out_dir, const ImportOptions& o) {
  const auto t0 = Clock::now();
  ImportResult r;
  r.photos.resize(s.photos.size());
  std::vector<Detected> det(s.photos.size());
  // Paper at least 5 mm from the sample (its edge, its shadow on a thin plate).
  const PaperPoints paper(s.board, s.polygon, 0.005 + 3 * s.height_m, s.reference.polygon);
  tbb::task_arena arena(merge_threads(s, o, &r));
  CropKeeper crops(r.crop_budget_mb);
  {
    Progress bar("import: merging and finding the board", s.photos.size(), o.progress);
    arena.execute([&] {
      tbb::parallel_for(size_t(0), s.photos.size(), [&](size_t i) {
        det[i] = detect_photo(s, i, o, paper, crops);
        bar.advance();
      });
    });
  }
  int markers = 0;
  for (size_t i = 0; i < det.size(); ++i) {
    ImportedPhoto& p = r.photos[i];
    for (const auto& im : s.photos[i].images) p.files.push_back(im.file);
    p.markers = det[i].markers;
    p.corners = static_cast<int>(det[i].corners.size());
    p.corners_dropped = static_cast<int>(det[i].dropped.size());
    p.saturated_pixels = det[i].saturated;
    p.raw = det[i].raw;
    markers += det[i].markers;
    if (s.camera_given && (det[i].width != s.camera.width || det[i].height != s.camera.height))
      throw Error(s.file + ": " + photo_name(s, i) + " is " + std::to_string(det[i].width) + "x" +
                  std::to_string(det[i].height) + ", the shoot's camera " +
                  std::to_string(s.camera.width) + "x" + std::to_string(s.camera.height));
    if (!s.camera_given && (det[i].width != det[0].width || det[i].height != det[0].height))
      throw Error(
          s.file + ": " + photo_name(s, i) + " is " + std::to_string(det[i].width) + "x" +
          std::to_string(det[i].height) + ", " + photo_name(s, 0) + " " +
          std::to_string(det[0].width) + "x" + std::to_string(det[0].height) +
          ": one camera at one setting is calibrated (crop or zoom changes the intrinsics)");
  }
  if (markers == 0) no_markers(s);
  r.seconds_detect = seconds_since(t0);
  const auto tc = Clock::now();
  solve_cameras(s, det, o, &r);
  // The lens's vignetting is centred on the principal point the calibration found.
  if (o.find_lamps && o.vignetting) arena.execute([&] { find_vignetting(s, det, &r); });
  for (size_t i = 0; i < det.size(); ++i) r.photos[i].lamps = det[i].lamps;
  r.seconds_calibrate = seconds_since(tc);
  r.warnings = lamp_warnings(s, r);
  if (o.find_lamps && s.reference_given()) scale_by_card(s, &r);
  r.intensities = intensity_note(s, r, o.find_lamps);
  size_t accepted = 0;
  for (const auto& p : r.photos) accepted += p.accepted;
  if (accepted == 0)
    throw Error(s.file + ": no photo can be used (" + r.photos[0].reason +
                " in the first); nothing written");

  const auto tw = Clock::now();
  write_folder_atomically(out_dir, OutputKind::kImportedCapture, [&](const std::string& dir) {
    Progress bar("import: writing views", s.photos.size(), o.progress);
    std::vector<ViewSpec> views(s.photos.size());
    // A view's writing holds its crop's geometry, a few times less than a merge holds: twice the
    // merges at once (at most the cores), the decodes among them at most the merges.
    DecodeGate gate(r.merge_threads);
    tbb::task_arena writers(
        std::min(tbb::info::default_concurrency(), std::max(1, 2 * r.merge_threads)));
    writers.execute([&] {
      tbb::parallel_for(size_t(0), s.photos.size(), [&](size_t i) {
        write_photo(s, i, det[i], dir, out_dir, o, gate, &r, &views[i]);
        bar.advance();
      });
    });
    CaptureSet set;
    set.camera = r.camera;
    set.color.encoding = ColorSpec::Encoding::kLinear;
    for (size_t i = 0; i < views.size(); ++i) {
      if (!r.photos[i].accepted) continue;
      r.photos[i].view = static_cast<int>(set.views.size());
      set.views.push_back(views[i]);
    }
    r.views = set.views.size();
    if (set.views.empty()) throw Error(s.file + ": no photo shows the sample; nothing written");
    set.provenance =
        nlohmann::json{
            {"tool", "aniso import"},
            {"shoot", relative_to(s.file, out_dir)},
            {"calibrated", r.calibrated},
            {"intensities", r.intensities},
            {"paper_reflectance_assumed",
             s.paper_given() || r.card.found || !o.find_lamps ? 0.0 : kAssumedPaperReflectance},
            {"report", "import_report.json"}}
            .dump();
    write_capture_json(set, join_path(dir, "capture.json"));
    r.seconds_write = seconds_since(tw);
    r.seconds = seconds_since(t0);
    write_json_file(join_path(dir, "import_report.json"), import_report_json(s, r, o));
  });
  return r;
}

}  // namespace aniso
