#include "fit/output/map_previews.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>

#include "core/color.h"
#include "core/image.h"
#include "io/files/files.h"
#include "io/images/image_io.h"

namespace aniso {

std::vector<MapPreview> map_preview_files(const std::string& material_path) {
  const std::string stem = std::filesystem::path(material_path).stem().string();
  std::vector<MapPreview> f;
  for (const char* k : {"kd", "ks", "n", "fiber"}) f.push_back({k, stem + "_" + k + ".png"});
  return f;
}

namespace {

// The hue of a fiber direction: the doubled angle round the colour wheel (0 and 180 degrees one
// colour), at full saturation and value.
void hue(double psi_deg, float rgb[3]) {
  const double h = std::fmod(2 * psi_deg / 60.0 + 12.0, 6.0);  // sextant of the wheel
  const int i = static_cast<int>(h);
  const float f = static_cast<float>(h - i), q = 1 - f;
  const float table[6][3] = {{1, f, 0}, {q, 1, 0}, {0, 1, f}, {0, q, 1}, {f, 0, 1}, {1, 0, q}};
  for (int c = 0; c < 3; ++c) rgb[c] = table[std::min(i, 5)][c];
}

}  // namespace

void write_map_previews(const std::string& material_path, const std::string& dir,
                        const TexelMaps& t, const std::vector<double>& kd,
                        const std::vector<double>& ks, const std::vector<double>& n,
                        const std::vector<double>& psi_deg) {
  const size_t N = static_cast<size_t>(t.w) * t.h;
  const int scale = std::max(1, (256 + std::min(t.w, t.h) - 1) / std::max(1, std::min(t.w, t.h)));
  double ks_max = 1e-12, ln_lo = INFINITY, ln_hi = -INFINITY;
  for (size_t i = 0; i < N; ++i) {
    for (int c = 0; c < 3; ++c) ks_max = std::max(ks_max, ks[3 * i + c]);
    if (n[i] > 0) ln_lo = std::min(ln_lo, std::log(n[i])), ln_hi = std::max(ln_hi, std::log(n[i]));
  }
  auto put = [&](const std::string& file, const std::function<void(size_t, float*)>& texel) {
    Image img(t.w * scale, t.h * scale, 3);
    for (int y = 0; y < t.h; ++y)
      for (int x = 0; x < t.w; ++x) {
        const size_t i = static_cast<size_t>(y) * t.w + x;
        float rgb[3];
        texel(i, rgb);
        const float dim = t.determined[i] ? 1.f : 0.25f;
        for (int c = 0; c < 3; ++c) {
          const float v = std::isfinite(rgb[c]) ? std::clamp(rgb[c] * dim, 0.f, 1.f) : 0.f;
          for (int dy = 0; dy < scale; ++dy)
            for (int dx = 0; dx < scale; ++dx) img.at(x * scale + dx, y * scale + dy, c) = v;
        }
      }
    write_png(join_path(dir, file), img, 8);
  };
  const std::vector<MapPreview> f = map_preview_files(material_path);
  put(f[0].file, [&](size_t i, float* rgb) {
    for (int c = 0; c < 3; ++c)
      rgb[c] = static_cast<float>(srgb_encode(std::min(1.0, kd[3 * i + c])));
  });
  put(f[1].file, [&](size_t i, float* rgb) {
    for (int c = 0; c < 3; ++c) rgb[c] = static_cast<float>(srgb_encode(ks[3 * i + c] / ks_max));
  });
  put(f[2].file, [&](size_t i, float* rgb) {
    const double v = ln_hi > ln_lo && n[i] > 0 ? (std::log(n[i]) - ln_lo) / (ln_hi - ln_lo) : 0.5;
    for (int c = 0; c < 3; ++c) rgb[c] = static_cast<float>(v);
  });
  put(f[3].file, [&](size_t i, float* rgb) { hue(psi_deg[i], rgb); });
}

}  // namespace aniso
