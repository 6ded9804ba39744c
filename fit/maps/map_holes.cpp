#include "fit/maps/map_holes.h"

#include <cmath>

namespace aniso::fitting {

std::vector<uint8_t> interior_holes(const TexelMaps& m) {
  const int w = m.w, h = m.row1 - m.row0;
  std::vector<uint8_t> hole(m.pixels.size(), 0);
  // Along each line (a row, then a column): the empty texels between its first and last covered.
  // The columns' first and last covered rows are found row by row, as the rows' (a scan down each
  // column takes a cache miss a texel).
  std::vector<int> first_row(static_cast<size_t>(w), -1), last_row(static_cast<size_t>(w), -1);
  for (int y = 0; y < h; ++y) {
    const int* row = m.pixels.data() + static_cast<size_t>(y) * w;
    int first = -1, last = -1;
    for (int x = 0; x < w; ++x)
      if (row[x] > 0) {
        last = x, first = first < 0 ? x : first;
        last_row[x] = y;
        if (first_row[x] < 0) first_row[x] = y;
      }
    for (int x = first + 1; x < last; ++x)
      if (row[x] == 0) hole[static_cast<size_t>(y) * w + x] = 1;
  }
  for (int y = 0; y < h; ++y) {
    const int* row = m.pixels.data() + static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x)
      if (row[x] == 0 && first_row[x] < y && y < last_row[x])
        hole[static_cast<size_t>(y) * w + x] = 1;
  }
  return hole;
}

WrittenValues written_values(const TexelMaps& m) {
  WrittenValues v{m.kd, m.ks, m.n, m.psi_deg, m.s};
  const std::vector<uint8_t> hole = interior_holes(m);
  const int w = m.w, h = m.row1 - m.row0;
  // The nearest determined texel from texel (x, y) along (dx, dy), and its distance; -1: none.
  auto nearest = [&](int x, int y, int dx, int dy, int* dist) -> long {
    for (int k = 1;; ++k) {
      const int xx = x + k * dx, yy = y + k * dy;
      if (xx < 0 || yy < 0 || xx >= w || yy >= h) return -1;
      const size_t j = static_cast<size_t>(yy) * w + xx;
      if (m.determined[j]) return *dist = k, static_cast<long>(j);
    }
  };
  constexpr double d2r = M_PI / 90;  // doubled angle
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!hole[i]) continue;
      int da = 0, db = 0;
      long a = nearest(x, y, 0, -1, &da), b = nearest(x, y, 0, 1, &db);
      if (a < 0 || b < 0) a = nearest(x, y, -1, 0, &da), b = nearest(x, y, 1, 0, &db);
      if (a < 0 || b < 0) continue;  // not between determined texels: the global values stay
      const double t = double(da) / (da + db);
      auto lerp = [&](const std::vector<double>& src, std::vector<double>* dst, int k) {
        for (int c = 0; c < k; ++c)
          (*dst)[k * i + c] = (1 - t) * src[k * a + c] + t * src[k * b + c];
      };
      lerp(m.kd, &v.kd, 3);
      lerp(m.ks, &v.ks, 3);
      lerp(m.n, &v.n, 1);
      if (!m.s.empty()) lerp(m.s, &v.s, 1);
      const double c2 = (1 - t) * std::cos(d2r * m.psi_deg[a]) + t * std::cos(d2r * m.psi_deg[b]);
      const double s2 = (1 - t) * std::sin(d2r * m.psi_deg[a]) + t * std::sin(d2r * m.psi_deg[b]);
      double deg = 0.5 * std::atan2(s2, c2) / (M_PI / 180);
      v.psi_deg[i] = deg < 0 ? deg + 180 : deg;
    }
  return v;
}

}  // namespace aniso::fitting
