#include "photo/shoot/board.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/text.h"
#include "photo/shoot/charuco_cv.h"

namespace aniso {

namespace {

struct DictName {
  const char* name;
  int id;
  int size;  // markers it holds
};
const DictName kDictionaries[] = {
    {"DICT_4X4_50", cv::aruco::DICT_4X4_50, 50},
    {"DICT_4X4_100", cv::aruco::DICT_4X4_100, 100},
    {"DICT_4X4_250", cv::aruco::DICT_4X4_250, 250},
    {"DICT_4X4_1000", cv::aruco::DICT_4X4_1000, 1000},
    {"DICT_5X5_50", cv::aruco::DICT_5X5_50, 50},
    {"DICT_5X5_100", cv::aruco::DICT_5X5_100, 100},
    {"DICT_5X5_250", cv::aruco::DICT_5X5_250, 250},
    {"DICT_5X5_1000", cv::aruco::DICT_5X5_1000, 1000},
    {"DICT_6X6_50", cv::aruco::DICT_6X6_50, 50},
    {"DICT_6X6_100", cv::aruco::DICT_6X6_100, 100},
    {"DICT_6X6_250", cv::aruco::DICT_6X6_250, 250},
    {"DICT_6X6_1000", cv::aruco::DICT_6X6_1000, 1000},
    {"DICT_7X7_50", cv::aruco::DICT_7X7_50, 50},
    {"DICT_7X7_100", cv::aruco::DICT_7X7_100, 100},
    {"DICT_7X7_250", cv::aruco::DICT_7X7_250, 250},
    {"DICT_7X7_1000", cv::aruco::DICT_7X7_1000, 1000},
};

const DictName& find_dictionary(const std::string& name) {
  for (const auto& d : kDictionaries)
    if (name == d.name) return d;
  throw Error("board: unknown --dictionary '" + name + "'" +
              did_you_mean(name, aruco_dictionary_names()) +
              " (one of OpenCV's predefined "
              "ArUco dictionaries, e.g. DICT_5X5_100)");
}

}  // namespace

cv::Ptr<cv::aruco::CharucoBoard> make_charuco_board(const BoardSpec& b) {
  return cv::aruco::CharucoBoard::create(
      b.squares_x, b.squares_y, static_cast<float>(b.square_m), static_cast<float>(b.marker_m),
      cv::aruco::getPredefinedDictionary(find_dictionary(b.dictionary).id));
}

const std::vector<std::string>& aruco_dictionary_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& d : kDictionaries) n.push_back(d.name);
    return n;
  }();
  return names;
}

int aruco_dictionary(const std::string& name) { return find_dictionary(name).id; }

void check_board(const BoardSpec& b) {
  if (b.squares_x < 3 || b.squares_y < 3 || b.squares_x > 100 || b.squares_y > 100)
    throw Error("board: --squares must be between 3x3 and 100x100 (got " +
                std::to_string(b.squares_x) + "x" + std::to_string(b.squares_y) + ")");
  if (!(b.square_m > 0) || !(b.marker_m > 0) || !(b.marker_m < b.square_m))
    throw Error("board: --marker-mm must be positive and smaller than --square-mm (got marker " +
                std::to_string(b.marker_m * 1e3) + " mm, square " +
                std::to_string(b.square_m * 1e3) + " mm)");
  const int markers = b.squares_x * b.squares_y / 2;
  const DictName& d = find_dictionary(b.dictionary);
  if (markers > d.size)
    throw Error("board: " + std::to_string(b.squares_x) + "x" + std::to_string(b.squares_y) +
                " squares need " + std::to_string(markers) + " markers; " + d.name + " holds " +
                std::to_string(d.size) + " (choose a larger dictionary, e.g. DICT_5X5_250)");
}

Image render_board(const BoardSpec& b, double dpi) {
  check_board(b);
  if (!(dpi >= 30 && dpi <= 2400)) throw Error("board: --dpi must be between 30 and 2400");
  const double px_per_m = dpi / 0.0254;
  const int w = static_cast<int>(std::lround(b.squares_x * b.square_m * px_per_m));
  const int h = static_cast<int>(std::lround(b.squares_y * b.square_m * px_per_m));
  if (static_cast<long long>(w) * h > (1LL << 28))
    throw Error("board: " + std::to_string(w) + "x" + std::to_string(h) +
                " pixels is too large: lower --dpi or the board size");
  cv::Mat m;
  make_charuco_board(b)->draw(cv::Size(w, h), m, 0, 1);
  Image img(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at(x, y, 0) = m.at<uint8_t>(y, x) / 255.f;
  return img;
}

Paper paper_named(const std::string& name) {
  if (name == "a4") return {"a4", 0.297, 0.210};
  if (name == "letter") return {"letter", 0.2794, 0.2159};
  if (name == "a3") return {"a3", 0.420, 0.297};
  throw Error("board: --paper: unknown paper '" + name + "'" +
              did_you_mean(name, {"a4", "letter", "a3", "none"}) + " (a4, letter, a3, none)");
}

double largest_square_on(const BoardSpec& b, const Paper& paper) {
  const double w = paper.w - 2 * kPaperMargin, h = paper.h - 2 * kPaperMargin - kCaptionSpace;
  return std::floor(std::min(w / b.squares_x, h / b.squares_y) * 1e4) / 1e4;
}

Image render_board_page(const BoardSpec& b, const Paper& paper, double dpi) {
  const double W = b.squares_x * b.square_m, H = b.squares_y * b.square_m;
  if (W > paper.w - 2 * kPaperMargin + 1e-9 ||
      H > paper.h - 2 * kPaperMargin - kCaptionSpace + 1e-9) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "board: %dx%d squares of %.1f mm (%.0f x %.0f mm) do not fit %s (%.0f x %.0f mm "
                  "landscape, %.0f mm margins and %.0f mm for the scale bar): at most %.1f mm "
                  "squares (--square-mm), fewer squares, or a larger --paper",
                  b.squares_x, b.squares_y, 1e3 * b.square_m, 1e3 * W, 1e3 * H, paper.name.c_str(),
                  1e3 * paper.w, 1e3 * paper.h, 1e3 * kPaperMargin, 1e3 * kCaptionSpace,
                  1e3 * largest_square_on(b, paper));
    throw Error(buf);
  }
  const Image board = render_board(b, dpi);
  const double px_per_m = dpi / 0.0254;
  const int pw = static_cast<int>(std::lround(paper.w * px_per_m));
  const int ph = static_cast<int>(std::lround(paper.h * px_per_m));
  cv::Mat page(ph, pw, CV_8U, cv::Scalar(255));
  // The board centred across, and in the height left above the caption.
  const int x0 = (pw - board.width) / 2;
  const int y0 = static_cast<int>(
      std::lround((ph - std::lround(kCaptionSpace * px_per_m) - board.height) / 2.0));
  for (int y = 0; y < board.height; ++y)
    for (int x = 0; x < board.width; ++x)
      page.at<uint8_t>(y0 + y, x0 + x) = static_cast<uint8_t>(std::lround(255 * board.at(x, y, 0)));
  // The scale bar: 100 mm, 1.5 mm thick, ticks every 10 mm, 4 mm below the board.
  const int bar = static_cast<int>(std::lround(0.100 * px_per_m));
  const int by = y0 + board.height + static_cast<int>(std::lround(0.004 * px_per_m));
  const int thick = std::max(2, static_cast<int>(std::lround(0.0015 * px_per_m)));
  cv::rectangle(page, cv::Rect(x0, by, bar, thick), cv::Scalar(0), cv::FILLED);
  for (int t = 0; t <= 10; ++t) {
    const int tx = x0 + static_cast<int>(std::lround(t * 0.010 * px_per_m));
    const int tick = static_cast<int>(std::lround((t % 5 == 0 ? 0.004 : 0.0025) * px_per_m));
    cv::rectangle(page, cv::Rect(std::min(tx, x0 + bar - thick), by, thick, thick + tick),
                  cv::Scalar(0), cv::FILLED);
  }
  char caption[256];
  std::snprintf(caption, sizeof caption,
                "aniso ChArUco %dx%d, squares %.1f mm, markers %.1f mm, %s; %s: print at 100 %% "
                "(no fit to page)",
                b.squares_x, b.squares_y, 1e3 * b.square_m, 1e3 * b.marker_m, b.dictionary.c_str(),
                paper.name == "letter" ? "US Letter"
                : paper.name == "a4"   ? "A4"
                                       : "A3");
  // Hershey simplex: about 22 px of cap height at scale 1; 2.2 mm here.
  const double scale = 0.0022 * px_per_m / 22;
  const int weight = std::max(1, static_cast<int>(std::lround(scale * 1.5)));
  cv::putText(page, "100 mm",
              cv::Point(x0 + bar + static_cast<int>(std::lround(0.003 * px_per_m)),
                        by + static_cast<int>(std::lround(0.003 * px_per_m))),
              cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0), weight, cv::LINE_AA);
  cv::putText(page, caption, cv::Point(x0, by + static_cast<int>(std::lround(0.0125 * px_per_m))),
              cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0), weight, cv::LINE_AA);
  Image out(pw, ph, 1);
  for (int y = 0; y < ph; ++y)
    for (int x = 0; x < pw; ++x) out.at(x, y, 0) = page.at<uint8_t>(y, x) / 255.f;
  return out;
}

std::vector<std::array<double, 2>> board_corners_m(const BoardSpec& b) {
  std::vector<std::array<double, 2>> out;
  const auto board = make_charuco_board(b);  // held: the corners belong to it
  for (const auto& p : board->chessboardCorners) out.push_back({p.x, p.y});
  return out;
}

std::vector<BoardCorner> detect_board(const Image& grey, const BoardSpec& b, int* markers) {
  std::vector<uint8_t> bytes(static_cast<size_t>(grey.width) * grey.height);
  for (int y = 0; y < grey.height; ++y)
    for (int x = 0; x < grey.width; ++x)
      bytes[static_cast<size_t>(y) * grey.width + x] = detector_byte(grey.at(x, y, 0));
  return detect_board(bytes.data(), grey.width, grey.height, b, markers);
}

std::vector<BoardCorner> detect_board(const uint8_t* grey, int width, int height,
                                      const BoardSpec& b, int* markers) {
  check_board(b);
  // OpenCV reads the caller's bytes in place.
  const cv::Mat m(height, width, CV_8U, const_cast<uint8_t*>(grey));
  const auto board = make_charuco_board(b);
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(m, board->dictionary, corners, ids);
  if (markers) *markers = static_cast<int>(ids.size());
  std::vector<BoardCorner> out;
  if (ids.empty()) return out;
  std::vector<cv::Point2f> cc;
  std::vector<int> cid;
  cv::aruco::interpolateCornersCharuco(corners, ids, m, board, cc, cid);
  for (size_t i = 0; i < cid.size(); ++i) out.push_back({cid[i], cc[i].x, cc[i].y});
  return out;
}

void shoot_skeleton(const BoardSpec& b, const std::string& board_file, nlohmann::json* j) {
  const double W = b.squares_x * b.square_m, H = b.squares_y * b.square_m;
  const double x0 = W / 3, x1 = 2 * W / 3, y0 = H / 3, y1 = 2 * H / 3;
  *j = {{"format", "aniso-shoot"},
        {"version", 1},
        {"board",
         {{"type", "charuco"},
          {"dictionary", b.dictionary},
          {"squares", {b.squares_x, b.squares_y}},
          {"square_m", b.square_m},
          {"marker_m", b.marker_m},
          {"printed_from", board_file}}},
        {"sample", {{"polygon_m", {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}}, {"tangent", {1, 0}}}},
        {"camera", nullptr},
        {"color", {{"encoding", "srgb"}}},
        {"photos",
         {{{"images",
            {{{"file", "photos/c0_l0_e0.png"}, {"exposure", 1.0}},
             {{"file", "photos/c0_l0_e1.png"}, {"exposure", 0.0625}}}},
           {"lights",
            {{{"type", "point"},
              {"position", {W / 2, -H, -0.45}},
              {"intensity", {1.0, 1.0, 1.0}}}}}}}}};
}

}  // namespace aniso
