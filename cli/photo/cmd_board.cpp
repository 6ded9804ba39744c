// aniso board: the printable ChArUco board and a shoot.json to fill in (photo/shoot/board.h).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/images/image_io.h"
#include "photo/shoot/board.h"

namespace aniso::cli {

Command add_board(CLI::App& app) {
  struct Args {
    // Fits A4 and US Letter landscape with 10 mm margins and the scale bar (240 x 168 mm).
    std::string out, shoot, squares = "10x7", dictionary = "DICT_5X5_100", paper = "a4";
    double square_mm = 24, marker_mm = 17, dpi = 300;
    bool force = false;
  };
  auto a = std::make_shared<Args>();
  auto* b = app.add_subcommand(
      "board",
      "The printable ChArUco calibration board for a photo shoot, and a shoot.json to "
      "fill in (then: aniso import shoot.json --out CAPTURE_DIR)");
  b->add_option("--out", a->out, "board image to write (PNG; print it at 100 % scale)")->required();
  b->add_option("--shoot", a->shoot,
                "the shoot.json skeleton (default: shoot.json beside --out; an existing one is "
                "kept: refused, or with --force moved aside to shoot.aniso-old-N.json)");
  b->add_option("--squares", a->squares, "squares across x down (WxH)")->capture_default_str();
  b->add_option("--square-mm", a->square_mm, "side of a chessboard square, mm")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1000.0));
  b->add_option("--marker-mm", a->marker_mm, "side of an ArUco marker inside a white square, mm")
      ->capture_default_str()
      ->check(CLI::Range(0.5, 1000.0));
  b->add_option("--dictionary", a->dictionary, "OpenCV ArUco dictionary")->capture_default_str();
  b->add_option("--paper", a->paper,
                "the sheet it prints on, landscape: a4, letter or a3 (the PNG is the whole page: "
                "the board within 10 mm margins, a 100 mm scale bar and a caption below it), or "
                "none (the board alone)")
      ->capture_default_str()
      ->check(CLI::IsMember({"a4", "letter", "a3", "none"}));
  b->add_option("--dpi", a->dpi, "print resolution (recorded in the PNG)")
      ->capture_default_str()
      ->check(CLI::Range(30.0, 2400.0));
  add_force_flag(b, &a->force);
  return {b, [a] {
            BoardSpec spec;
            parse_size(a->squares, &spec.squares_x, &spec.squares_y);
            spec.square_m = a->square_mm / 1000;
            spec.marker_m = a->marker_mm / 1000;
            spec.dictionary = a->dictionary;
            check_board(spec);
            const std::string shoot =
                a->shoot.empty() ? join_path(parent_dir(a->out), "shoot.json") : a->shoot;
            check_outputs_apart({a->out, shoot}, {});
            check_output_file(a->out, OutputKind::kBoard, a->force);
            check_output_file(shoot, OutputKind::kShoot, a->force);
            const Image img = a->paper == "none"
                                  ? render_board(spec, a->dpi)
                                  : render_board_page(spec, paper_named(a->paper), a->dpi);
            write_png(a->out, img, 8, a->dpi);
            nlohmann::json j;
            shoot_skeleton(spec, relative_to(a->out, parent_dir(shoot)), &j);
            write_json_file(shoot, j);
            std::printf(
                "board: %dx%d squares of %.1f mm (markers %.1f mm, %s) = %.1f x %.1f mm on %s, "
                "%dx%d px at %.0f dpi -> %s\n"
                "board: print at 100 %% scale (no fit-to-page) and measure the scale bar (100 mm) "
                "or one square (%.1f mm); then fill in %s (sample outline, lamp positions, "
                "photos)\n",
                spec.squares_x, spec.squares_y, a->square_mm, a->marker_mm, spec.dictionary.c_str(),
                spec.squares_x * a->square_mm, spec.squares_y * a->square_mm,
                a->paper == "none" ? "its own" : a->paper.c_str(), img.width, img.height, a->dpi,
                a->out.c_str(), a->square_mm, shoot.c_str());
            return 0;
          }};
}

}  // namespace aniso::cli
