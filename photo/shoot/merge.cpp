#include "photo/shoot/merge.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include "core/color.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/images/image_io.h"
#include "photo/shoot/board.h"
#include "photo/shoot/raw.h"

namespace aniso {

namespace {

constexpr double kNearBlack = 0.02;  // of full scale above the black level

// One exposure of the bracket: an integer PNG or JPEG read row by row as codes (`rows`), or any
// other file (RAW, EXR, TIFF) read whole (`whole`).
struct Shot {
  std::unique_ptr<CodeRows> rows;
  LoadedImage whole;
  double exposure;
  std::string path;
  bool raw = false;  // decoded linearly by LibRaw: `color` does not apply
  int width() const { return rows ? rows->width : whole.image.width; }
  int height() const { return rows ? rows->height : whole.image.height; }
  int bits() const { return rows ? rows->bits : whole.bits; }
};

std::vector<Shot> read_bracket(const Shoot& s, size_t i, RawDevelop develop,
                               std::vector<RawInfo>* raw_info) {
  std::vector<Shot> shots;
  for (const auto& im : s.photos[i].images) {
    const std::string path = join_path(s.dir, im.file);
    Shot shot;
    shot.exposure = im.exposure;
    shot.path = path;
    if (is_raw_photo(path)) {
      RawInfo info;
      shot.rows = read_raw_rows(path, &info, develop);
      shot.raw = true;
      raw_info->push_back(info);
    } else if (!(shot.rows = read_image_rows(path))) {
      shot.whole = read_image(path);
      if (!shot.whole.bits) {
        size_t bad = 0;
        for (const float v : shot.whole.image.px) bad += !std::isfinite(v);
        if (bad > 0)
          throw Error(path + ": " + std::to_string(bad) +
                      " values are NaN or infinite; a float photo holds finite radiance (fix or "
                      "export it again)");
      }
    }
    shots.push_back(std::move(shot));
    const Shot& first = shots.front();
    const Shot& last = shots.back();
    if (last.width() != first.width() || last.height() != first.height())
      throw Error(s.file + ": photos[" + std::to_string(i) +
                  "]: the bracket's images differ in "
                  "size: " +
                  first.path + " is " + std::to_string(first.width()) + "x" +
                  std::to_string(first.height()) + ", " + last.path + " is " +
                  std::to_string(last.width()) + "x" + std::to_string(last.height()) +
                  " (one photo = one camera position, exposures only change)");
    if (last.bits() && !last.raw && !s.color.encoding_given)
      throw Error(s.file + ": color.encoding: " + last.path +
                  " holds integer codes; say how they "
                  "decode: \"srgb\" (camera JPEG/PNG), {\"gamma\": g} or \"linear\" (raw data)");
  }
  return shots;
}

// The stored value at and above which a code is clipped.
double saturation_level(const Shoot& s, int bits, bool raw) {
  if (s.color.saturation_given && !raw) return s.color.saturation;
  if (!bits) return INFINITY;
  const double q = bits == 8 ? 255.0 : 65535.0;
  return 1.0 - 0.5 / q;  // the largest code
}

// The detector's 8-bit image: luminance scaled so that its 99th percentile (of unclipped pixels,
// every 7th) is white, sRGB-encoded through a table (4096 levels are finer than the 8 bits the
// detector sees); clipped pixels white.
std::vector<uint8_t> detection_image(const Image& rgb, const std::vector<uint8_t>& saturated) {
  const size_t n = static_cast<size_t>(rgb.width) * rgb.height;
  auto lum = [&](size_t p) {
    return 0.2126f * rgb.px[3 * p] + 0.7152f * rgb.px[3 * p + 1] + 0.0722f * rgb.px[3 * p + 2];
  };
  std::vector<float> sorted;
  for (size_t p = 0; p < n; p += 7)
    if (!saturated[p]) sorted.push_back(lum(p));
  double white = 1;
  if (!sorted.empty()) {
    auto nth = sorted.begin() + static_cast<long>(0.99 * (sorted.size() - 1));
    std::nth_element(sorted.begin(), nth, sorted.end());
    white = *nth > 0 ? *nth : 1;
  }
  std::array<uint8_t, 4097> enc;
  for (size_t i = 0; i < enc.size(); ++i)
    enc[i] = detector_byte(static_cast<float>(srgb_encode(i / 4096.0)));
  std::vector<uint8_t> grey(n);
  const float scale = static_cast<float>(4096 / white);
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, n, 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t p = r.begin(); p < r.end(); ++p)
          grey[p] = saturated[p]
                        ? 255
                        : enc[static_cast<size_t>(std::clamp(lum(p) * scale, 0.f, 4096.f))];
      });
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

MergedPhoto merge_bracket(const Shoot& s, size_t i, RawDevelop develop) {
  MergedPhoto m;
  std::vector<Shot> shots = read_bracket(s, i, develop, &m.raw);
  const int w = shots[0].width(), h = shots[0].height();
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
  for (size_t k = 0; k < shots.size(); ++k)
    sat[k] = saturation_level(s, shots[k].bits(), shots[k].raw);
  auto classify = [&](size_t k, double stored) {
    const Shot& sh = shots[k];
    const double black = sh.raw ? 0.0 : s.color.black_level;  // LibRaw subtracts its own
    const double lin = sh.raw ? stored : sh.bits() ? decode_code(stored, s.color) : stored;
    const Kind kind = stored >= sat[k]                           ? kClipped
                      : sh.bits() && stored - black < kNearBlack ? kDark
                                                                 : kUse;
    return Code{static_cast<float>(lin / sh.exposure), kind};
  };
  std::vector<std::vector<Code>> table(shots.size());
  for (size_t k = 0; k < shots.size(); ++k) {
    if (!shots[k].bits()) continue;
    const int q = shots[k].bits() == 8 ? 255 : 65535;
    for (int c = 0; c <= q; ++c) table[k].push_back(classify(k, static_cast<double>(c) / q));
  }
  // Row by row: each exposure's row as codes of the three channels (a grey image's one channel
  // for all three), then the merge of each value over the exposures.
  const size_t n = shots.size(), row_values = static_cast<size_t>(w) * 3;
  std::vector<std::vector<Code>> rows(n);
  // Where every exposure is an RGB file of codes, a value's usable part is two table reads an
  // exposure: its weighted radiance and its weight (both 0 for a dark or clipped code), summed as
  // the general merge below sums them; only values no exposure holds go the general way.
  struct Weighted {
    float radiance_e, e;
  };
  bool all_codes = true;
  for (const Shot& sh : shots) all_codes &= sh.rows && sh.rows->channels == 3;
  std::vector<std::vector<Weighted>> weighted(n);
  if (all_codes)
    for (size_t k = 0; k < n; ++k) {
      const float e = static_cast<float>(shots[k].exposure);
      for (const Code& c : table[k])
        weighted[k].push_back(c.kind == kUse ? Weighted{e * c.radiance, e} : Weighted{0, 0});
    }
  if (!all_codes)
    for (auto& r : rows) r.resize(row_values);
  std::vector<const uint16_t*> codes(n);
  auto fill_row = [&](size_t k, int y) {
    Shot& sh = shots[k];
    Code* out = rows[k].data();
    if (sh.rows) {
      codes[k] = sh.rows->next();
      if (all_codes) return;  // read through `weighted`, and `table` where needed
      const Code* t = table[k].data();
      if (sh.rows->channels == 3)
        for (size_t v = 0; v < row_values; ++v) out[v] = t[codes[k][v]];
      else
        for (int x = 0; x < w; ++x) out[3 * x] = out[3 * x + 1] = out[3 * x + 2] = t[codes[k][x]];
      return;
    }
    const Image& img = sh.whole.image;
    const float* px = img.px.data() + static_cast<size_t>(y) * w * img.channels;
    const float scale = static_cast<float>(table[k].size()) - 1;
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const float stored = px[x * img.channels + (img.channels == 1 ? 0 : c)];
        out[3 * x + c] = table[k].empty() ? classify(k, stored)
                                          : table[k][static_cast<int>(stored * scale + 0.5f)];
      }
  };
  // Value v of exposure k's current row.
  auto value_code = [&](size_t k, size_t v) {
    return all_codes ? table[k][codes[k][v]] : rows[k][v];
  };
  // The bracket's own ratios: where two exposures both hold a usable value, their radiances
  // (value / exposure) agree; a median ratio far from 1 means exposures swapped or mistyped.
  // Green, every 13th pixel of the image.
  constexpr size_t kRatioStep = 13;
  std::vector<std::vector<float>> ratio(n);
  for (int y = 0; y < h; ++y) {
    for (size_t k = 0; k < n; ++k) fill_row(k, y);
    const size_t row0 = static_cast<size_t>(y) * w;
    for (size_t p = (row0 + kRatioStep - 1) / kRatioStep * kRatioStep; p < row0 + w;
         p += kRatioStep)
      for (size_t k = 1; k < n; ++k) {
        const Code a = value_code(0, 3 * (p - row0) + 1), b = value_code(k, 3 * (p - row0) + 1);
        if (a.kind == kUse && b.kind == kUse && a.radiance > 0 && b.radiance > 0)
          ratio[k].push_back(b.radiance / a.radiance);
      }
    float* out = m.rgb.px.data() + row0 * 3;
    uint8_t* clipped_px = m.saturated.data() + row0;
    for (size_t v = 0; v < row_values; ++v) {
      if (all_codes) {
        float sum = 0, wsum = 0;
        for (size_t k = 0; k < n; ++k) {
          const Weighted& t = weighted[k][codes[k][v]];
          sum += t.radiance_e;
          wsum += t.e;
        }
        if (wsum > 0) {
          out[v] = sum / wsum;
          continue;
        }
      }
      float sum = 0, wsum = 0, dark = 0, dark_e = 0, clipped = 0;
      for (size_t k = 0; k < n; ++k) {
        const Code code = value_code(k, v);
        const float e = static_cast<float>(shots[k].exposure);
        if (code.kind == kUse) {  // weight = exposure
          sum += e * code.radiance;
          wsum += e;
        } else if (code.kind == kDark) {  // kept: the longest exposure's, as a last resort
          if (e > dark_e) dark = code.radiance, dark_e = e;
        } else {  // clipped: a lower bound only
          clipped = std::max(clipped, code.radiance);
        }
      }
      float value = clipped;  // a lower bound; the pixel is left out of the fit
      if (wsum > 0)
        value = sum / wsum;
      else if (dark_e > 0)
        value = dark;
      else
        clipped_px[v / 3] = 1;
      out[v] = value;
    }
  }
  for (size_t k = 1; k < n; ++k) {
    constexpr size_t kEnough = 200;
    constexpr float kFar = 2;  // a factor past any exposure's own error
    if (ratio[k].size() < kEnough) continue;
    std::nth_element(ratio[k].begin(), ratio[k].begin() + ratio[k].size() / 2, ratio[k].end());
    const float r = ratio[k][ratio[k].size() / 2];
    if (r < 1 / kFar || r > kFar) {
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    ": photos[%zu].images[%zu].exposure: %s is %.3g times as bright as %s (the "
                    "median over %zu pixels both hold), but the exposures say %.3g; swapped or "
                    "mistyped? (exposure is relative: 1, 0.25, 0.0625 for steps of 2 stops)",
                    i, k, shots[k].path.c_str(), r * shots[k].exposure / shots[0].exposure,
                    shots[0].path.c_str(), ratio[k].size(), shots[k].exposure / shots[0].exposure);
      throw Error(s.file + buf);
    }
  }
  shots.clear();  // the decoders and any whole image, before the detection image is made
  for (uint8_t v : m.saturated) m.saturated_pixels += v;
  m.grey = detection_image(m.rgb, m.saturated);
  return m;
}

}  // namespace aniso
