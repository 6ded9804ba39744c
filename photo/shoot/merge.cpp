#include "photo/shoot/merge.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/color.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/images/image_io.h"
#include "photo/shoot/raw.h"

namespace aniso {

namespace {

constexpr double kNearBlack = 0.02;  // of full scale above the black level

struct Shot {
  LoadedImage li;
  double exposure;
  std::string path;
  bool raw = false;  // decoded linearly by LibRaw: `color` does not apply
};

std::vector<Shot> read_bracket(const Shoot& s, size_t i, std::vector<RawInfo>* raw_info) {
  std::vector<Shot> shots;
  for (const auto& im : s.photos[i].images) {
    const std::string path = join_path(s.dir, im.file);
    if (is_raw_photo(path)) {
      RawInfo info;
      shots.push_back({read_raw(path, &info), im.exposure, path, true});
      raw_info->push_back(info);
    } else {
      shots.push_back({read_image(path), im.exposure, path});
      if (!shots.back().li.bits) {
        size_t bad = 0;
        for (const float v : shots.back().li.image.px) bad += !std::isfinite(v);
        if (bad > 0)
          throw Error(path + ": " + std::to_string(bad) +
                      " values are NaN or infinite; a float photo holds finite radiance (fix or "
                      "export it again)");
      }
    }
    const Shot& first = shots.front();
    const Shot& last = shots.back();
    if (last.li.image.width != first.li.image.width ||
        last.li.image.height != first.li.image.height)
      throw Error(s.file + ": photos[" + std::to_string(i) +
                  "]: the bracket's images differ in "
                  "size: " +
                  first.path + " is " + std::to_string(first.li.image.width) + "x" +
                  std::to_string(first.li.image.height) + ", " + last.path + " is " +
                  std::to_string(last.li.image.width) + "x" + std::to_string(last.li.image.height) +
                  " (one photo = one camera position, exposures only change)");
    if (last.li.bits && !last.raw && !s.color.encoding_given)
      throw Error(s.file + ": color.encoding: " + last.path +
                  " holds integer codes; say how they "
                  "decode: \"srgb\" (camera JPEG/PNG), {\"gamma\": g} or \"linear\" (raw data)");
  }
  return shots;
}

// The stored value at and above which a code is clipped.
double saturation_level(const Shoot& s, const LoadedImage& li, bool raw) {
  if (s.color.saturation_given && !raw) return s.color.saturation;
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
  // sRGB through a table: 4096 levels are finer than the 8-bit image the detector sees.
  std::vector<float> enc(4097);
  for (size_t i = 0; i < enc.size(); ++i) enc[i] = static_cast<float>(srgb_encode(i / 4096.0));
  Image grey(w, h, 1);
  const float scale = static_cast<float>(4096 / white);
  for (size_t p = 0; p < lum.size(); ++p)
    grey.px[p] =
        saturated[p] ? 1.f : enc[static_cast<size_t>(std::clamp(lum[p] * scale, 0.f, 4096.f))];
  return grey;
}

}  // namespace

MergedCrop crop_merged(const MergedPhoto& m, int x0, int y0, int x1, int y1) {
  MergedCrop c;
  c.x0 = std::clamp(x0, 0, m.rgb.width - 1);
  c.y0 = std::clamp(y0, 0, m.rgb.height - 1);
  c.w = std::clamp(x1, c.x0, m.rgb.width - 1) - c.x0 + 1;
  c.h = std::clamp(y1, c.y0, m.rgb.height - 1) - c.y0 + 1;
  c.rgb = Image(c.w, c.h, 3);
  c.saturated.resize(static_cast<size_t>(c.w) * c.h);
  for (int y = 0; y < c.h; ++y)
    for (int x = 0; x < c.w; ++x) {
      const size_t src = static_cast<size_t>(c.y0 + y) * m.rgb.width + c.x0 + x;
      for (int ch = 0; ch < 3; ++ch) c.rgb.at(x, y, ch) = m.rgb.px[3 * src + ch];
      c.saturated[static_cast<size_t>(y) * c.w + x] = m.saturated[src];
    }
  return c;
}

MergedPhoto merge_bracket(const Shoot& s, size_t i) {
  MergedPhoto m;
  const std::vector<Shot> shots = read_bracket(s, i, &m.raw);
  const int w = shots[0].li.image.width, h = shots[0].li.image.height;
  m.rgb = Image(w, h, 3);
  m.saturated.assign(static_cast<size_t>(w) * h, 0);
  // Every stored value of an exposure is one of: used (radiance = linear / exposure), near black,
  // or clipped. Integer codes are classified once per code value through a table.
  enum Kind : uint8_t { kUse, kDark, kClipped };
  struct Code {
    float radiance;
    Kind kind;
  };
  std::vector<double> sat(shots.size());  // per exposure, once (float images classify per pixel)
  for (size_t k = 0; k < shots.size(); ++k) sat[k] = saturation_level(s, shots[k].li, shots[k].raw);
  auto classify = [&](size_t k, double stored) {
    const Shot& sh = shots[k];
    const double black = sh.raw ? 0.0 : s.color.black_level;  // LibRaw subtracts its own
    const double lin = sh.raw ? stored : sh.li.bits ? decode_code(stored, s.color) : stored;
    const Kind kind = stored >= sat[k]                            ? kClipped
                      : sh.li.bits && stored - black < kNearBlack ? kDark
                                                                  : kUse;
    return Code{static_cast<float>(lin / sh.exposure), kind};
  };
  std::vector<std::vector<Code>> table(shots.size());
  for (size_t k = 0; k < shots.size(); ++k) {
    if (!shots[k].li.bits) continue;
    const int q = shots[k].li.bits == 8 ? 255 : 65535;
    for (int c = 0; c <= q; ++c) table[k].push_back(classify(k, static_cast<double>(c) / q));
  }
  // Per exposure: its pixels, channel count, table (or none) and weight, hoisted out of the loop.
  struct Src {
    const float* px;
    int channels;
    const Code* table;
    float scale;  // stored value -> table index
    float e;
  };
  std::vector<Src> src;
  for (size_t k = 0; k < shots.size(); ++k)
    src.push_back({shots[k].li.image.px.data(), shots[k].li.image.channels,
                   table[k].empty() ? nullptr : table[k].data(),
                   static_cast<float>(table[k].size()) - 1, static_cast<float>(shots[k].exposure)});
  // The bracket's own ratios: where two exposures both hold a usable value, their radiances
  // (value / exposure) agree; a median ratio far from 1 means exposures swapped or mistyped.
  auto code_at = [&](size_t k, size_t p) {
    const Src& sr = src[k];
    const float stored = sr.px[p * sr.channels + (sr.channels == 1 ? 0 : 1)];  // green
    return sr.table ? sr.table[static_cast<int>(stored * sr.scale + 0.5f)] : classify(k, stored);
  };
  for (size_t k = 1; k < src.size(); ++k) {
    std::vector<float> ratio;
    for (size_t p = 0; p < static_cast<size_t>(w) * h; p += 13) {
      const Code a = code_at(0, p), b = code_at(k, p);
      if (a.kind == kUse && b.kind == kUse && a.radiance > 0 && b.radiance > 0)
        ratio.push_back(b.radiance / a.radiance);
    }
    constexpr size_t kEnough = 200;
    constexpr float kFar = 2;  // a factor past any exposure's own error
    if (ratio.size() < kEnough) continue;
    std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
    const float r = ratio[ratio.size() / 2];
    if (r < 1 / kFar || r > kFar) {
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    ": photos[%zu].images[%zu].exposure: %s is %.3g times as bright as %s (the "
                    "median over %zu pixels both hold), but the exposures say %.3g; swapped or "
                    "mistyped? (exposure is relative: 1, 0.25, 0.0625 for steps of 2 stops)",
                    i, k, shots[k].path.c_str(), r * shots[k].exposure / shots[0].exposure,
                    shots[0].path.c_str(), ratio.size(), shots[k].exposure / shots[0].exposure);
      throw Error(s.file + buf);
    }
  }
  tbb::parallel_for(0, h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      for (int c = 0; c < 3; ++c) {
        float sum = 0, wsum = 0, dark = 0, dark_e = 0, clipped = 0;
        for (size_t k = 0; k < src.size(); ++k) {
          const Src& sr = src[k];
          const float stored = sr.px[p * sr.channels + (sr.channels == 1 ? 0 : c)];
          const Code code =
              sr.table ? sr.table[static_cast<int>(stored * sr.scale + 0.5f)] : classify(k, stored);
          if (code.kind == kUse) {  // weight = exposure
            sum += sr.e * code.radiance;
            wsum += sr.e;
          } else if (code.kind == kDark) {  // kept: the longest exposure's, as a last resort
            if (sr.e > dark_e) dark = code.radiance, dark_e = sr.e;
          } else {  // clipped: a lower bound only
            clipped = std::max(clipped, code.radiance);
          }
        }
        float v = clipped;  // a lower bound; the pixel is left out of the fit
        if (wsum > 0)
          v = sum / wsum;
        else if (dark_e > 0)
          v = dark;
        else
          m.saturated[p] = 1;
        m.rgb.px[3 * p + c] = v;
      }
    }
  });
  for (uint8_t v : m.saturated) m.saturated_pixels += v;
  m.grey = detection_image(m.rgb, m.saturated);
  return m;
}

}  // namespace aniso
