#include "photo/import/overlay.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "io/images/image_io.h"

namespace aniso {

OverlayImage overlay_image(const std::vector<uint8_t>& grey, int width, int height) {
  OverlayImage o;
  o.shrink = overlay_shrink(width, height);
  o.width = width / o.shrink, o.height = height / o.shrink;
  o.grey.resize(static_cast<size_t>(o.width) * o.height);
  const int f = o.shrink, area = f * f;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      int sum = 0;
      for (int dy = 0; dy < f; ++dy)
        for (int dx = 0; dx < f; ++dx)
          sum += grey[static_cast<size_t>(y * f + dy) * width + x * f + dx];
      o.grey[static_cast<size_t>(y) * o.width + x] = static_cast<uint8_t>((sum + area / 2) / area);
    }
  return o;
}

void write_overlay(const std::string& path, const OverlayImage& img, const OverlayMarks& m) {
  const int w = img.width, h = img.height, f = img.shrink;
  cv::Mat bgr(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint8_t g = img.grey[static_cast<size_t>(y) * w + x];
      bgr.at<cv::Vec3b>(y, x) = {g, g, g};
    }
  // The mask in overlay pixels (each tinted once, however many photo pixels it holds).
  std::vector<uint8_t> tint(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < m.mask_h; ++y)
    for (int x = 0; x < m.mask_w; ++x) {
      if (!m.mask[static_cast<size_t>(y) * m.mask_w + x]) continue;
      const int ox = (m.mask_x0 + x) / f, oy = (m.mask_y0 + y) / f;
      if (ox < w && oy < h) tint[static_cast<size_t>(oy) * w + ox] = 1;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!tint[static_cast<size_t>(y) * w + x]) continue;
      cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      p = {static_cast<uint8_t>(std::min(255, p[0] / 2 + 128)), static_cast<uint8_t>(p[1] / 2),
           static_cast<uint8_t>(p[2] / 2)};
    }
  const int s = std::max(1, w / 640);              // line width and mark size grow with the image
  auto pt = [f](const std::array<double, 2>& p) {  // photo pixel centres to overlay pixels
    return cv::Point(static_cast<int>(std::lround((p[0] + 0.5) / f - 0.5)),
                     static_cast<int>(std::lround((p[1] + 0.5) / f - 0.5)));
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
  std::vector<uint8_t> rgb(static_cast<size_t>(w) * h * 3);
  cv::Mat out(h, w, CV_8UC3, rgb.data());
  cv::cvtColor(bgr, out, cv::COLOR_BGR2RGB);
  write_rgb8_png(path, rgb, w, h);
}

}  // namespace aniso
