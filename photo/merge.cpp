#include "photo/merge.h"

#include <algorithm>
#include <cmath>

#include "core/color.h"
#include "core/error.h"
#include "io/files.h"
#include "io/image_io.h"

namespace aniso {

namespace {

constexpr double kNearBlack = 0.02;  // of full scale above the black level

struct Shot {
  LoadedImage li;
  double exposure;
  std::string path;
};

std::vector<Shot> read_bracket(const Shoot& s, size_t i) {
  std::vector<Shot> shots;
  for (const auto& im : s.photos[i].images) {
    const std::string path = join_path(s.dir, im.file);
    const std::string ext = lower_ext(path);
    if (ext == ".dng" || ext == ".cr2" || ext == ".nef" || ext == ".arw")
      throw Error(path + ": RAW photos are not decoded by this build (LibRaw is not linked yet); "
                  "convert them to 16-bit linear TIFF (e.g. `dcraw -4 -T`) and state "
                  "\"color\": {\"encoding\": \"linear\"} in the shoot");
    shots.push_back({read_image(path), im.exposure, path});
    const Shot& first = shots.front();
    const Shot& last = shots.back();
    if (last.li.image.width != first.li.image.width ||
        last.li.image.height != first.li.image.height)
      throw Error(s.file + ": photos[" + std::to_string(i) + "]: the bracket's images differ in "
                  "size: " + first.path + " is " + std::to_string(first.li.image.width) + "x" +
                  std::to_string(first.li.image.height) + ", " + last.path + " is " +
                  std::to_string(last.li.image.width) + "x" + std::to_string(last.li.image.height) +
                  " (one photo = one camera position, exposures only change)");
    if (last.li.bits && !s.color.encoding_given)
      throw Error(s.file + ": color.encoding: " + last.path + " holds integer codes; say how they "
                  "decode: \"srgb\" (camera JPEG/PNG), {\"gamma\": g} or \"linear\" (raw data)");
  }
  return shots;
}

// The stored value at and above which a code is clipped.
double saturation_level(const Shoot& s, const LoadedImage& li) {
  if (s.color.saturation_given) return s.color.saturation;
  if (!li.bits) return INFINITY;
  const double q = li.bits == 8 ? 255.0 : 65535.0;
  return 1.0 - 0.5 / q;  // the largest code
}

Image detection_image(const Image& rgb, const std::vector<uint8_t>& saturated) {
  const int w = rgb.width, h = rgb.height;
  std::vector<float> lum(static_cast<size_t>(w) * h);
  for (size_t p = 0; p < lum.size(); ++p)
    lum[p] = 0.2126f * rgb.px[3 * p] + 0.7152f * rgb.px[3 * p + 1] + 0.0722f * rgb.px[3 * p + 2];
  std::vector<float> sorted;
  for (size_t p = 0; p < lum.size(); p += 7)
    if (!saturated[p]) sorted.push_back(lum[p]);
  double white = 1;
  if (!sorted.empty()) {
    auto nth = sorted.begin() + static_cast<long>(0.99 * (sorted.size() - 1));
    std::nth_element(sorted.begin(), nth, sorted.end());
    white = *nth > 0 ? *nth : 1;
  }
  Image grey(w, h, 1);
  for (size_t p = 0; p < lum.size(); ++p)
    grey.px[p] = saturated[p] ? 1.f : static_cast<float>(srgb_encode(std::clamp(lum[p] / white, 0.0, 1.0)));
  return grey;
}

}  // namespace

MergedPhoto merge_bracket(const Shoot& s, size_t i) {
  const std::vector<Shot> shots = read_bracket(s, i);
  const int w = shots[0].li.image.width, h = shots[0].li.image.height;
  MergedPhoto m;
  m.rgb = Image(w, h, 3);
  m.saturated.assign(static_cast<size_t>(w) * h, 0);
  std::vector<double> sat(shots.size());
  for (size_t k = 0; k < shots.size(); ++k) sat[k] = saturation_level(s, shots[k].li);
  for (size_t p = 0; p < m.saturated.size(); ++p)
    for (int c = 0; c < 3; ++c) {
      double sum = 0, wsum = 0, dark = NAN, dark_e = 0, clipped = 0;
      for (size_t k = 0; k < shots.size(); ++k) {
        const Image& im = shots[k].li.image;
        const double code = im.px[p * im.channels + (im.channels == 1 ? 0 : c)];
        const double e = shots[k].exposure;
        const double lin = shots[k].li.bits ? decode_code(code, s.color) : code;
        if (code >= sat[k]) {  // clipped: a lower bound only
          clipped = std::max(clipped, lin / e);
          continue;
        }
        if (shots[k].li.bits && code - s.color.black_level < kNearBlack) {
          if (e > dark_e) dark = lin / e, dark_e = e;  // the longest exposure's dark value
          continue;
        }
        sum += e * (lin / e);
        wsum += e;
      }
      double v;
      if (wsum > 0) {
        v = sum / wsum;
      } else if (dark_e > 0) {
        v = dark;
      } else {
        v = clipped;  // a lower bound; the pixel is left out of the fit
        m.saturated[p] = 1;
      }
      m.rgb.px[3 * p + c] = static_cast<float>(v);
    }
  for (uint8_t v : m.saturated) m.saturated_pixels += v;
  m.grey = detection_image(m.rgb, m.saturated);
  return m;
}

}  // namespace aniso
