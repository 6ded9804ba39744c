#include "photo/import/plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/angles.h"
#include "core/error.h"

namespace aniso {

namespace {

Vec3 sample_centre(const Shoot& s) {
  Vec3 c{0, 0, -s.height_m};
  for (const auto& p : s.polygon) c.x += p[0] / s.polygon.size(), c.y += p[1] / s.polygon.size();
  return c;
}

// The board's normal toward the camera side, the tangent and the fiber direction in the board
// frame.
const Vec3 kNormal{0, 0, -1};
Vec3 fiber_of(const Shoot& s, const PlanOptions& o) {
  const Vec3 U{s.tangent[0], s.tangent[1], 0};
  const Vec3 W = cross(kNormal, U);
  const double psi = deg_to_rad(o.fiber_given ? o.fiber_deg : 0.0);
  return U * std::cos(psi) + W * std::sin(psi);
}

// Where a camera at `azimuth` (board x toward y, degrees) and the plan's elevation and distance
// sits, and its lamp on the mirror direction.
PlannedPhoto ring_photo(const Vec3& c, double azimuth_deg, const PlanOptions& o) {
  const double a = deg_to_rad(azimuth_deg), el = deg_to_rad(o.elevation_deg);
  const Vec3 v{std::cos(el) * std::cos(a), std::cos(el) * std::sin(a), -std::sin(el)};
  PlannedPhoto p;
  p.azimuth_deg = azimuth_deg;
  p.camera = c + v * o.camera_m;
  p.lamp = c + Vec3(-v.x, -v.y, v.z) * o.lamp_m;
  return p;
}

// Points of the sample: a 9 x 9 grid over its outline's bounds, those inside it.
std::vector<Vec3> sample_points(const Shoot& s) {
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const auto& p : s.polygon)
    x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::min(y0, p[1]),
    y1 = std::max(y1, p[1]);
  std::vector<Vec3> out;
  constexpr int kGrid = 9;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const double x = x0 + (x1 - x0) * (i + 0.5) / kGrid, y = y0 + (y1 - y0) * (j + 0.5) / kGrid;
      if (inside_polygon(s.polygon, x, y)) out.push_back({x, y, -s.height_m});
    }
  return out;
}

std::string vec_text(const Vec3& v) {
  char buf[80];
  std::snprintf(buf, sizeof buf, "(%.3f, %.3f, %.3f)", v.x, v.y, v.z);
  return buf;
}

}  // namespace

std::vector<PlannedPhoto> plan_ring(const Shoot& s, const PlanOptions& o) {
  if (o.ring < 1 || o.ring > 360) throw Error("plan: --ring must be 1 to 360 photos");
  if (!(o.elevation_deg >= 10 && o.elevation_deg <= 85))
    throw Error("plan: --elevation must be 10 to 85 degrees above the board");
  if (!(o.camera_m > 0.05 && o.camera_m < 5) || !(o.lamp_m > 0.05 && o.lamp_m < 5))
    throw Error("plan: --camera-m and --lamp-m are distances in metres, 0.05 to 5");
  const Vec3 c = sample_centre(s);
  std::vector<PlannedPhoto> out;
  for (int i = 0; i < o.ring; ++i) out.push_back(ring_photo(c, 360.0 * i / o.ring, o));
  return out;
}

std::vector<PlanPhoto> photos_of(const CaptureSet& set) {
  std::vector<PlanPhoto> out;
  for (const auto& v : set.views) {
    PlanPhoto p;
    p.camera = v.world_from_camera.translation();
    for (const auto& l : v.lights)
      if (l.type != Light::Type::kDirectional) p.lamps.push_back(l.position);
    out.push_back(p);
  }
  return out;
}

std::vector<PlanPhoto> photos_of(const std::vector<PlannedPhoto>& ring) {
  std::vector<PlanPhoto> out;
  for (const auto& r : ring) out.push_back({r.camera, {r.lamp}});
  return out;
}

Coverage lobe_coverage(const Shoot& s, const std::vector<PlanPhoto>& photos, const PlanOptions& o,
                       const std::string& noun) {
  Coverage cov;
  const Vec3 T = fiber_of(s, o), B = cross(kNormal, T), c = sample_centre(s);
  const std::vector<Vec3> pts = sample_points(s);
  for (const auto& ph : photos) {
    size_t on = 0, seen = 0;
    for (const auto& p : pts) {
      const Vec3 V = normalize(ph.camera - p);
      if (dot(V, kNormal) <= 0) continue;
      for (const auto& lamp : ph.lamps) {
        const Vec3 L = normalize(lamp - p);
        if (dot(L, kNormal) <= 0) continue;
        const double x = std::abs(dot(L, T) + dot(V, T));
        int b = 0;
        while (b + 1 < Coverage::kBands && x >= Coverage::kBandEdges[b + 1]) ++b;
        ++cov.band[b], ++cov.samples, ++seen;
        on += x < Coverage::kBandEdges[1];
      }
    }
    const double f = seen ? static_cast<double>(on) / seen : 0;
    const Vec3 d = ph.camera - c;
    double az = rad_to_deg(std::atan2(dot(d, B), dot(d, T)));
    if (az < 0) az += 360;
    cov.highlight_fraction.push_back(f);
    cov.azimuth_deg.push_back(az);
    if (on > 0) ++cov.sectors[static_cast<int>(std::fmod(az, 180.0) / 45) % 4];
  }
  // What is missing, each with what to do.
  char buf[400];
  for (size_t i = 0; i < photos.size(); ++i)
    if (cov.highlight_fraction[i] == 0) {
      const double world_az =
          rad_to_deg(std::atan2(photos[i].camera.y - c.y, photos[i].camera.x - c.x));
      PlanOptions at = o;
      const Vec3 d = photos[i].camera - c;
      at.elevation_deg = rad_to_deg(std::asin(std::clamp(-d.z / length(d), -1.0, 1.0)));
      at.lamp_m = photos[i].lamps.empty() ? o.lamp_m : length(photos[i].lamps[0] - c);
      std::snprintf(buf, sizeof buf,
                    "%s %zu: its highlight misses the sample; with the lamp at %s m (the "
                    "camera's mirror direction) it falls on it",
                    noun.c_str(), i, vec_text(ring_photo(c, world_az, at).lamp).c_str());
      cov.missing.push_back(buf);
    }
  for (int k = 0; k < 4; ++k)
    if (cov.sectors[k] == 0) {
      // A camera in the middle of the sector (its azimuth from T's on the board), and its mirror
      // lamp.
      const double world_az = rad_to_deg(std::atan2(T.y, T.x)) + 45.0 * k + 22.5;
      const PlannedPhoto p = ring_photo(c, world_az, o);
      std::snprintf(buf, sizeof buf,
                    "no photo shows the highlight with the camera %d-%d degrees round from the "
                    "fiber direction (or opposite): the fiber direction is measured from "
                    "highlights seen from all round; add one with the camera at %s and the lamp "
                    "at %s m",
                    45 * k, 45 * (k + 1), vec_text(p.camera).c_str(), vec_text(p.lamp).c_str());
      cov.missing.push_back(buf);
    }
  for (int b = 1; b < 4; ++b)
    if (cov.band[b] == 0) {
      std::snprintf(buf, sizeof buf,
                    "no sample point at |L.T + V.T| from %.2f to %.2f: n is measured from how "
                    "the highlight falls off beside it; move the lamp %.0f-%.0f cm along the "
                    "fiber direction in a few photos",
                    Coverage::kBandEdges[b], Coverage::kBandEdges[b + 1],
                    100 * o.lamp_m * Coverage::kBandEdges[b],
                    100 * o.lamp_m * Coverage::kBandEdges[b + 1]);
      cov.missing.push_back(buf);
    }
  return cov;
}

}  // namespace aniso
