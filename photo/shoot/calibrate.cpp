#include "photo/shoot/calibrate.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/lens.h"
#include "photo/shoot/charuco_cv.h"

namespace aniso {

namespace {

void to_cv(const std::vector<BoardCorner>& in, std::vector<cv::Point2f>* pts,
           std::vector<int>* ids) {
  for (const auto& c : in) {
    pts->emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
    ids->push_back(c.id);
  }
}

cv::Mat camera_matrix(const Intrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

cv::Mat dist_coeffs(const Intrinsics& k) {
  return (cv::Mat_<double>(1, 5) << k.distortion[0], k.distortion[1], k.distortion[2],
          k.distortion[3], k.distortion[4]);
}

Mat4 pose_from(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Mat4 m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = R.at<double>(r, c);
    m(r, 3) = tvec.at<double>(r);
  }
  return m;
}

}  // namespace

Mat4 rigid_inverse(const Mat4& m) {
  Mat4 out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = m(c, r);
  for (int r = 0; r < 3; ++r)
    out(r, 3) = -(out(r, 0) * m(0, 3) + out(r, 1) * m(1, 3) + out(r, 2) * m(2, 3));
  return out;
}

Calibration calibrate_charuco(const BoardSpec& b,
                              const std::vector<std::vector<BoardCorner>>& views, int width,
                              int height, const CalibrationHolds& holds) {
  const auto board = make_charuco_board(b);
  std::vector<std::vector<cv::Point2f>> pts(views.size());
  std::vector<std::vector<int>> ids(views.size());
  for (size_t i = 0; i < views.size(); ++i) to_cv(views[i], &pts[i], &ids[i]);
  // Without CALIB_USE_INTRINSIC_GUESS OpenCV takes only fx / fy (1) from K and puts the principal
  // point at the image centre.
  cv::Mat K = cv::Mat::eye(3, 3, CV_64F), dist, std_intr, std_extr, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  Calibration out;
  int flags = cv::CALIB_FIX_K3;
  if (holds.square_pixels) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  if (holds.centre) flags |= cv::CALIB_FIX_PRINCIPAL_POINT;
  try {
    out.rms_px = cv::aruco::calibrateCameraCharuco(
        pts, ids, board, cv::Size(width, height), K, dist, rvecs, tvecs, std_intr, std_extr,
        per_view, flags,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
  } catch (const cv::Exception& e) {
    throw Error(std::string("calibration failed in OpenCV: ") + e.what());
  }
  Intrinsics& k = out.camera;
  k.width = width;
  k.height = height;
  k.fx = K.at<double>(0, 0);
  k.fy = K.at<double>(1, 1);
  k.cx = K.at<double>(0, 2);
  k.cy = K.at<double>(1, 2);
  for (int i = 0; i < 5 && i < static_cast<int>(dist.total()); ++i)
    k.distortion[i] = dist.at<double>(i);
  for (int i = 0; i < 4 && i < static_cast<int>(std_intr.total()); ++i)
    out.sigma[i] = std_intr.at<double>(i);
  for (size_t i = 0; i < views.size(); ++i) {
    out.view_rms_px.push_back(per_view.at<double>(static_cast<int>(i)));
    out.camera_from_board.push_back(pose_from(rvecs[i], tvecs[i]));
  }
  return out;
}

bool board_pose(const BoardSpec& b, const std::vector<BoardCorner>& corners, const Intrinsics& k,
                Mat4* camera_from_board) {
  std::vector<cv::Point2f> pts;
  std::vector<int> ids;
  to_cv(corners, &pts, &ids);
  cv::Mat rvec, tvec;
  try {
    if (!cv::aruco::estimatePoseCharucoBoard(pts, ids, make_charuco_board(b), camera_matrix(k),
                                             dist_coeffs(k), rvec, tvec))
      return false;
  } catch (const cv::Exception&) {
    return false;
  }
  rvec.convertTo(rvec, CV_64F);
  tvec.convertTo(tvec, CV_64F);
  *camera_from_board = pose_from(rvec, tvec);
  return true;
}

bool board_homography(const std::vector<BoardCorner>& corners, const BoardSpec& b,
                      std::array<double, 9>* H) {
  if (corners.size() < 4) return false;
  const auto obj = board_corners_m(b);
  std::vector<cv::Point2f> src, dst;
  for (const auto& c : corners) {
    src.emplace_back(static_cast<float>(obj.at(c.id)[0]), static_cast<float>(obj.at(c.id)[1]));
    dst.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
  }
  cv::Mat h;
  try {
    h = cv::findHomography(src, dst, 0);
  } catch (const cv::Exception&) {
    return false;
  }
  if (h.empty()) return false;
  for (int i = 0; i < 9; ++i) (*H)[i] = h.at<double>(i / 3, i % 3);
  return true;
}

double reprojection_rms(const BoardSpec& b, const std::vector<BoardCorner>& corners,
                        const Intrinsics& k, const Mat4& camera_from_board) {
  const auto obj = board_corners_m(b);
  double sum = 0;
  for (const auto& c : corners) {
    const Vec3 pc = camera_from_board.point({obj.at(c.id)[0], obj.at(c.id)[1], 0});
    double px, py;
    project_point(k, pc, &px, &py);
    sum += (px - c.x) * (px - c.x) + (py - c.y) * (py - c.y);
  }
  return corners.empty() ? 0 : std::sqrt(sum / corners.size());
}

}  // namespace aniso
