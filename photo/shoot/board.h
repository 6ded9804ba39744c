// The printable calibration board of a photo shoot (docs/formats.md "Photo shoot"): an OpenCV
// ChArUco board (OpenCV 4.6's aruco module) at a physical size, and the shoot.json skeleton that
// names it. The board frame is OpenCV's: origin at the top-left outer corner as drawn, x right, y
// down the printed image, metres; z = x × y points into the board.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/image.h"

namespace aniso {

struct BoardSpec {
  int squares_x = 10, squares_y = 8;
  double square_m = 0.030, marker_m = 0.022;
  std::string dictionary = "DICT_5X5_100";
};

// The predefined ArUco dictionaries by OpenCV's name; an unknown name is an error listing them.
int aruco_dictionary(const std::string& name);
const std::vector<std::string>& aruco_dictionary_names();

// Throws with the option's name when the board cannot be made (marker not smaller than its
// square, too few squares, more markers than the dictionary holds).
void check_board(const BoardSpec& b);

// The board at `dpi` dots per inch (one pixel per dot), black on white, no margin: what to print
// at 100 % scale. Grey, values 0 or 1.
Image render_board(const BoardSpec& b, double dpi);

// A sheet of paper, landscape, in metres.
struct Paper {
  std::string name;  // "a4", "letter", "a3"
  double w = 0, h = 0;
};
// "a4", "letter" or "a3"; throws naming the value otherwise.
Paper paper_named(const std::string& name);
// Margins and the space below the board for its scale bar and caption, metres.
inline constexpr double kPaperMargin = 0.010, kCaptionSpace = 0.022;
// The largest square side (metres, whole tenths of a mm) at which b's squares fit on `paper`
// with the margins and caption space.
double largest_square_on(const BoardSpec& b, const Paper& paper);
// The whole page at `dpi`: the board at its printed size, centred in the margins, and below it a
// 100 mm scale bar with 10 mm ticks and a caption (board, sizes, paper, "print at 100 %").
// Throws, naming the largest square that fits, where the board does not fit the paper.
Image render_board_page(const BoardSpec& b, const Paper& paper, double dpi);

// The inner chessboard corners in the board frame (metres), in OpenCV's id order.
std::vector<std::array<double, 2>> board_corners_m(const BoardSpec& b);

// The board's inner corners found in a photo (grey, values in [0, 1]): id (OpenCV's order, as
// board_corners_m) and position in pixels (OpenCV's convention: pixel centres at integers),
// refined to sub-pixel. Also how many markers were seen.
struct BoardCorner {
  int id = 0;
  double x = 0, y = 0;
};
std::vector<BoardCorner> detect_board(const Image& grey, const BoardSpec& b,
                                      int* markers = nullptr);
// A grey value in [0, 1] as the byte the detector sees.
inline uint8_t detector_byte(double v) {
  return static_cast<uint8_t>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
}
// The same on an 8-bit image of width x height, row by row (the image above is read through
// detector_byte).
std::vector<BoardCorner> detect_board(const uint8_t* grey, int width, int height,
                                      const BoardSpec& b, int* markers = nullptr);

// A shoot.json to fill in: the board, a sample polygon in the middle third, camera null (to be
// calibrated), sRGB images, and one example photo entry to copy.
void shoot_skeleton(const BoardSpec& b, const std::string& board_file, nlohmann::json* j);

}  // namespace aniso
