// bench/ internal: what the suites share (timing, JSON entries, memory, errors against truth).
#pragma once
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "core/angles.h"
#include "core/timer.h"
#include "io/files/json_util.h"
#include "models/material.h"

namespace aniso::benchutil {

using jsonu::json;
using Clock = SteadyClock;
inline double since(Clock::time_point t) { return seconds_since(t); }

// The median of a few timings (the upper one of an even count's middle two).
inline double median_of(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

inline json entry(const std::string& suite, const std::string& name, double ours, double baseline,
                  const std::string& unit, double error) {
  json e = {{"suite", suite}, {"name", name}, {"ours", ours}, {"unit", unit}};
  e["baseline"] = std::isfinite(baseline) ? json(baseline) : json(nullptr);
  e["ratio"] = std::isfinite(baseline) && ours != 0 ? json(baseline / ours) : json(nullptr);
  e["error"] = std::isfinite(error) ? json(error) : json(nullptr);
  return e;
}

inline void target(json* e, const std::string& what, bool met, const std::string& why_missed = "") {
  (*e)["target"] = what;
  (*e)["met"] = met;
  if (!met && !why_missed.empty()) (*e)["why_missed"] = why_missed;
}

// Peak resident memory (kB) of this process so far.
inline long peak_rss_kb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}
inline long current_rss_kb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}

struct Errs {
  double kd = 0, ks = 0, n = 0, psi = 0, topo = 0;
  double worst() const { return std::max({kd, ks, n, psi / 180.0}); }
};
inline Errs errors_of(const Material& m, const Material& t) {
  Errs e;
  for (int c = 0; c < 3; ++c) {
    e.kd = std::max(e.kd, std::abs(m.kd[c] - t.kd[c]) / t.kd[c]);
    e.ks = std::max(e.ks, std::abs(m.ks[c] - t.ks[c]) / t.ks[c]);
  }
  e.n = std::abs(m.n - t.n) / t.n;
  e.psi = fiber_deg_distance(m.fiber_angle_deg, t.fiber_angle_deg);
  e.topo = std::abs(m.uniform_s() - t.uniform_s());
  return e;
}

nlohmann::json bench_fit(const std::string& work, bool quick);
nlohmann::json bench_fit_process(const std::string& work, bool quick);
nlohmann::json bench_fiber(bool quick);
nlohmann::json bench_measured(bool quick);

}  // namespace aniso::benchutil
