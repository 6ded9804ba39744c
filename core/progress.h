// A progress bar on stderr, shown only when stderr is a terminal. Thread-safe `advance`.
#pragma once
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <mutex>
#include <string>

namespace aniso {

class Progress {
 public:
  Progress(std::string label, size_t total, bool enabled = true)
      : label_(std::move(label)), total_(total), on_(enabled && ::isatty(2)) {}
  ~Progress() { finish(); }
  void advance(size_t n = 1) {
    const size_t done = done_ += n;
    if (!on_) return;
    const int pct = total_ ? static_cast<int>(100.0 * done / total_) : 100;
    if (pct == last_.load()) return;
    std::lock_guard<std::mutex> lock(mu_);
    if (pct == last_) return;
    last_ = pct;
    const int bar = pct * 30 / 100;
    std::fprintf(stderr, "\r%s [%.*s%*s] %3d%%", label_.c_str(), bar,
                 "##############################", 30 - bar, "", pct);
    std::fflush(stderr);
  }
  void finish() {
    if (on_ && !finished_) std::fprintf(stderr, "\n");
    finished_ = true;
  }

 private:
  std::string label_;
  size_t total_;
  bool on_;
  bool finished_ = false;
  std::atomic<size_t> done_{0};
  std::atomic<int> last_{-1};
  std::mutex mu_;
};

}  // namespace aniso
