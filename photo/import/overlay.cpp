#include "photo/import/overlay.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "io/images/image_io.h"

namespace aniso {

void write_overlay(const std::string& path, const Image& grey, const OverlayMarks& m) {
  cv::Mat bgr(grey.height, grey.width, CV_8UC3);
  for (int y = 0; y < grey.height; ++y)
    for (int x = 0; x < grey.width; ++x) {
      const auto g =
          static_cast<uint8_t>(std::lround(255 * std::clamp(grey.at(x, y, 0), 0.f, 1.f)));
      bgr.at<cv::Vec3b>(y, x) = {g, g, g};
    }
  for (int y = 0; y < m.mask_h; ++y)
    for (int x = 0; x < m.mask_w; ++x) {
      if (!m.mask[static_cast<size_t>(y) * m.mask_w + x]) continue;
      cv::Vec3b& p = bgr.at<cv::Vec3b>(m.mask_y0 + y, m.mask_x0 + x);
      p = {static_cast<uint8_t>(std::min(255, p[0] / 2 + 128)), static_cast<uint8_t>(p[1] / 2),
           static_cast<uint8_t>(p[2] / 2)};
    }
  const int s = std::max(1, grey.width / 640);  // line width and mark size grow with the image
  auto pt = [](const std::array<double, 2>& p) {
    return cv::Point(static_cast<int>(std::lround(p[0])), static_cast<int>(std::lround(p[1])));
  };
  if (m.outline.size() > 1) {
    std::vector<cv::Point> poly;
    for (const auto& p : m.outline) poly.push_back(pt(p));
    cv::polylines(bgr, poly, true, {255, 96, 0}, s, cv::LINE_AA);
  }
  for (const auto& p : m.reprojected)
    cv::drawMarker(bgr, pt(p), {0, 0, 255}, cv::MARKER_CROSS, 10 * s, s, cv::LINE_AA);
  for (const auto& p : m.found) cv::circle(bgr, pt(p), 5 * s, {0, 220, 0}, s, cv::LINE_AA);
  for (const auto& p : m.dropped) cv::circle(bgr, pt(p), 5 * s, {0, 220, 255}, s, cv::LINE_AA);
  cv::putText(bgr, m.label, {8 * s, 20 * s}, cv::FONT_HERSHEY_SIMPLEX, 0.5 * s, {0, 0, 0}, 3 * s,
              cv::LINE_AA);
  cv::putText(bgr, m.label, {8 * s, 20 * s}, cv::FONT_HERSHEY_SIMPLEX, 0.5 * s, {255, 255, 255}, s,
              cv::LINE_AA);
  Image out(grey.width, grey.height, 3);
  for (int y = 0; y < grey.height; ++y)
    for (int x = 0; x < grey.width; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = bgr.at<cv::Vec3b>(y, x)[2 - c] / 255.f;
  write_png(path, out, 8);
}

}  // namespace aniso
