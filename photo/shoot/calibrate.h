// Camera calibration and board pose from detected ChArUco corners (OpenCV 4.6's aruco module:
// calibrateCameraCharuco, estimatePoseCharucoBoard), and the reprojection error of a pose through
// the lens model of core/lens.h.
#pragma once
#include <array>
#include <vector>

#include "core/camera.h"
#include "core/vec.h"
#include "photo/shoot/board.h"

namespace aniso {

struct Calibration {
  Intrinsics camera;                    // k3 held at zero (see calibrate_charuco)
  double rms_px = 0;                    // over every corner of every photo
  std::array<double, 4> sigma{};        // one standard deviation of fx, fy, cx, cy (pixels)
  std::vector<double> view_rms_px;      // per photo, in the order given
  std::vector<Mat4> camera_from_board;  // per photo
};

// Intrinsics, distortion k1 k2 p1 p2 (k3 fixed at zero: with tens of photos of a flat board it is
// poorly determined and trades off against k1, k2) and every photo's pose. Each photo needs at
// least 6 corners. Throws with OpenCV's message if the solve fails.
// What the photos may leave undetermined, held instead: square pixels (fx = fy: every photo tilts
// the board about the same image axis, as a camera held upright while walking round the board
// does), and the principal point at the image centre (few photos).
struct CalibrationHolds {
  bool square_pixels = false;
  bool centre = false;
};
Calibration calibrate_charuco(const BoardSpec& b,
                              const std::vector<std::vector<BoardCorner>>& views, int width,
                              int height, const CalibrationHolds& holds = {});

// The board's pose in a photo for a known camera; false when OpenCV finds none.
bool board_pose(const BoardSpec& b, const std::vector<BoardCorner>& corners, const Intrinsics& k,
                Mat4* camera_from_board);

// Root mean square distance, in pixels, between the corners found and the board corners projected
// through `camera_from_board` and the lens.
double reprojection_rms(const BoardSpec& b, const std::vector<BoardCorner>& corners,
                        const Intrinsics& k, const Mat4& camera_from_board);

// Board plane (metres) -> pixels, fitted to the corners found with no lens model (RANSAC-free
// least squares): where board points land, well enough to crop a photo before calibration.
// False with fewer than 4 corners.
bool board_homography(const std::vector<BoardCorner>& corners, const BoardSpec& b,
                      std::array<double, 9>* H);

// The rigid inverse of a rigid transform.
Mat4 rigid_inverse(const Mat4& m);

}  // namespace aniso
