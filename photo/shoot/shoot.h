// The photo shoot of docs/formats.md ("Photo shoot"): a sample on a printed ChArUco board, photos
// each with its lights and an exposure bracket. Read and checked here, before anything is decoded,
// so that a person's mistakes (a missing photo, a polygon off the board, a lamp behind the board)
// stop the import with a message naming the file and key and nothing written.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "core/camera.h"
#include "io/formats/capture.h"
#include "models/light.h"
#include "photo/shoot/board.h"

namespace aniso {

struct ShootImage {
  std::string file;  // as written in the shoot (relative to its folder)
  double exposure = 1.0;
};

struct ShootPhoto {
  std::vector<ShootImage> images;  // the exposure bracket, any order
  std::vector<Light> lights;       // board frame
  // Per light: how well its position was measured (position_sigma_m), metres.
  std::vector<double> position_sigma_m;
};

// A lamp's position as a person measures it with a tape: 2 cm unless the shoot says.
inline constexpr double kDefaultLampSigmaM = 0.02;

struct Shoot {
  std::string file, dir;  // shoot.json and the folder its relative paths resolve against
  BoardSpec board;
  std::vector<std::array<double, 2>> polygon;  // sample outline on the board, metres
  double height_m = 0;                         // sample surface at z = -height_m
  std::array<double, 2> tangent{1, 0};         // reference tangent U in board x, y (unit)
  bool camera_given = false;                   // false: calibrate from the photos
  Intrinsics camera;
  ColorSpec color;
  // board.paper_reflectance: the printed paper's diffuse reflectance (RGB); all 0 where the shoot
  // gives none, and k_d, k_s are then relative to an assumed paper (photo/lamps/lamps.h).
  RGB paper_reflectance{0, 0, 0};
  bool paper_given() const { return paper_reflectance[0] > 0; }
  // reference: a grey card of known diffuse reflectance lying on the board, its outline in board
  // metres; no polygon where the shoot has none. Through the lamps found from the paper it gives
  // the paper's reflectance, and so absolute intensities (photo/lamps/lamps.h).
  struct GreyCard {
    std::vector<std::array<double, 2>> polygon;
    RGB reflectance{0, 0, 0};
  } reference;
  bool reference_given() const { return !reference.polygon.empty(); }
  std::vector<ShootPhoto> photos;
};

// Reads and checks shoot.json: keys, board, polygon inside the board, lights on the printed side
// (z < 0), every image file present.
Shoot read_shoot(const std::string& path);

// Writes a shoot (used by the simulator, so the file it writes is the one `import` reads).
void write_shoot(const Shoot& s, const std::string& path);

// Point-in-polygon (even-odd) and the distance from a point to the polygon's outline, metres.
bool inside_polygon(const std::vector<std::array<double, 2>>& poly, double x, double y);
double distance_to_outline(const std::vector<std::array<double, 2>>& poly, double x, double y);

}  // namespace aniso
