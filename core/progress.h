// How the library tells the program what it is doing while it works: a long phase's advance, a
// status line that replaces itself (a solver's iterations) and a line to keep. The library never
// writes to the terminal itself; options carry a ProgressSink (null: silent) and the program
// chooses where it goes (aniso's commands: cli/terminal_progress.h).
#pragma once
#include <atomic>
#include <mutex>
#include <string>

namespace aniso {

class ProgressSink {
 public:
  virtual ~ProgressSink() = default;
  // `label`'s phase has done `done` of `total` (percent steps only; from one thread at a time).
  virtual void advance(const std::string& label, size_t done, size_t total) const = 0;
  // `label`'s phase is over.
  virtual void finish(const std::string& label) const = 0;
  // A line that replaces the last one ("fit: iteration 12, cost 0.5"); "" takes it away.
  virtual void status(const std::string& text) const = 0;
  // A line to keep: what the work chose on the way (the fit's model, a second pass it takes).
  virtual void note(const std::string& text) const = 0;
};

// One phase's progress toward `total` steps through `sink` (null: silent). Thread-safe `advance`;
// the sink hears of each whole percent once.
class Progress {
 public:
  Progress(std::string label, size_t total, const ProgressSink* sink)
      : label_(std::move(label)), total_(total), sink_(sink) {}
  ~Progress() { finish(); }
  void advance(size_t n = 1) {
    const size_t done = done_ += n;
    if (!sink_) return;
    const int pct = total_ ? static_cast<int>(100.0 * double(done) / double(total_)) : 100;
    if (pct == last_.load()) return;
    std::lock_guard<std::mutex> lock(mu_);
    if (pct == last_) return;
    last_ = pct;
    sink_->advance(label_, done, total_);
  }
  void finish() {
    if (sink_ && !finished_) sink_->finish(label_);
    finished_ = true;
  }

 private:
  std::string label_;
  size_t total_;
  const ProgressSink* sink_;
  bool finished_ = false;
  std::atomic<size_t> done_{0};
  std::atomic<int> last_{-1};
  std::mutex mu_;
};

}  // namespace aniso
