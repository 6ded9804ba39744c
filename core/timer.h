// Wall-clock seconds since a point: the timings every report prints.
#pragma once
#include <chrono>

namespace aniso {

using SteadyClock = std::chrono::steady_clock;

inline double seconds_since(SteadyClock::time_point t) {
  return std::chrono::duration<double>(SteadyClock::now() - t).count();
}

}  // namespace aniso
