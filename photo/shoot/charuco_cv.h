// The OpenCV ChArUco board of a BoardSpec. Internal to photo/*.cpp: it pulls in OpenCV's aruco
// headers, so no header includes it.
#pragma once
#include <opencv2/aruco/charuco.hpp>

#include "photo/shoot/board.h"

namespace aniso {

cv::Ptr<cv::aruco::CharucoBoard> make_charuco_board(const BoardSpec& b);

}  // namespace aniso
