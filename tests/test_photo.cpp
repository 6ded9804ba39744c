// Photo shoots (issue 9): the printable board and finding it again.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/files.h"
#include "io/image_io.h"
#include "photo/board.h"
#include "test_util.h"

namespace aniso {
namespace {

// The printed board is found again by OpenCV's aruco detector: every marker, every inner corner,
// each where the board frame of FORMAT.md puts it (metres times pixels per metre, OpenCV's pixel
// centres), to a fraction of a pixel.
TEST(Board, RenderedBoardIsFoundWhereTheBoardFrameSaysItIs) {
  for (const BoardSpec& b : {BoardSpec{}, BoardSpec{7, 5, 0.04, 0.03, "DICT_4X4_50"}}) {
    const double dpi = 100, ppm = dpi / 0.0254;
    const Image img = render_board(b, dpi);
    EXPECT_EQ(img.width, std::lround(b.squares_x * b.square_m * ppm));
    int markers = 0;
    const std::vector<BoardCorner> found = detect_board(img, b, &markers);
    EXPECT_EQ(markers, b.squares_x * b.squares_y / 2);
    const auto expect = board_corners_m(b);
    ASSERT_EQ(found.size(), expect.size());
    ASSERT_EQ(expect.size(), size_t((b.squares_x - 1) * (b.squares_y - 1)));
    double worst = 0, mx = 0, my = 0;
    for (const BoardCorner& c : found) {
      const double ex = expect[c.id][0] * ppm - 0.5, ey = expect[c.id][1] * ppm - 0.5;
      worst = std::max(worst, std::hypot(c.x - ex, c.y - ey));
      mx += (c.x - ex) / found.size();
      my += (c.y - ey) / found.size();
    }
    std::printf(
        "%dx%d %s board at %.0f dpi: %d markers, %zu corners, mean offset (%.3f, %.3f) "
        "px, worst %.3f px from the board frame\n",
        b.squares_x, b.squares_y, b.dictionary.c_str(), dpi, markers, found.size(), mx, my, worst);
    // Square edges are drawn on whole pixels (11.8 px squares here): up to half a pixel each way.
    EXPECT_LT(worst, 0.75);
    EXPECT_LT(std::hypot(mx, my), 0.3);  // no offset of the frame itself
  }
}

TEST(Board, BadBoardsAreRefusedWithTheOption) {
  BoardSpec b;
  b.marker_m = b.square_m;
  EXPECT_THROW(check_board(b), Error);
  b = BoardSpec{};
  b.dictionary = "DICT_5X5_10O";
  try {
    check_board(b);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("DICT_5X5_100"), std::string::npos) << e.what();
  }
  b = BoardSpec{};
  b.squares_x = 20;
  b.squares_y = 20;  // 200 markers: more than DICT_5X5_100 holds
  EXPECT_THROW(check_board(b), Error);
  // A blank page has no board.
  Image blank(200, 150, 1, 1.f);
  int markers = -1;
  EXPECT_TRUE(detect_board(blank, BoardSpec{}, &markers).empty());
  EXPECT_EQ(markers, 0);
}

// `aniso board` writes the PNG with its print resolution and a shoot.json skeleton, and never
// replaces a shoot.json that is already there (it holds a person's measurements).
TEST(Board, CommandWritesBoardAndSkeletonAndKeepsAnExistingShoot) {
  const std::string dir = test::tmp_dir("board");
  auto r = test::run_cli("board --out " + dir + "/board.png --dpi 150 --squares 6x4");
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string png = read_text_file(dir + "/board.png");
  const auto at = png.find("pHYs");
  ASSERT_NE(at, std::string::npos);
  const auto u8 = [&](size_t i) { return static_cast<uint32_t>(static_cast<uint8_t>(png[i])); };
  const uint32_t ppm = u8(at + 4) << 24 | u8(at + 5) << 16 | u8(at + 6) << 8 | u8(at + 7);
  EXPECT_EQ(ppm, 5906u);  // 150 dpi in pixels per metre
  EXPECT_EQ(read_image(dir + "/board.png").image.width, std::lround(6 * 0.03 * 150 / 0.0254));
  const auto j = nlohmann::json::parse(read_text_file(dir + "/shoot.json"));
  EXPECT_EQ(j["format"], "aniso-shoot");
  EXPECT_EQ(j["board"]["squares"], nlohmann::json({6, 4}));
  EXPECT_TRUE(j["camera"].is_null());
  test::edit_json(dir + "/shoot.json", [](nlohmann::json& s) { s["note"] = "mine"; });
  r = test::run_cli("board --out " + dir + "/board2.png");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("shoot.json"), std::string::npos) << r.output;
  EXPECT_EQ(nlohmann::json::parse(read_text_file(dir + "/shoot.json"))["note"], "mine");
  r = test::run_cli("board --out " + dir + "/b3.png --marker-mm 31");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--marker-mm"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace aniso
