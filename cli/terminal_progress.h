// The commands' progress sink (core/progress.h): a bar and a status line on stderr where stderr is
// a terminal, nothing of them in a log or a pipe; the lines to keep always.
#pragma once
#include <unistd.h>

#include <cstdio>
#include <string>

#include "core/progress.h"

namespace aniso {

// The bar and status line on stderr where it is a terminal; silent elsewhere (a log, a pipe).
class TerminalProgress : public ProgressSink {
 public:
  void advance(const std::string& label, size_t done, size_t total) const override {
    if (!on_) return;
    const int pct = total ? static_cast<int>(100.0 * double(done) / double(total)) : 100;
    const int bar = pct * 30 / 100;
    std::fprintf(stderr, "\r%s [%.*s%*s] %3d%%", label.c_str(), bar,
                 "##############################", 30 - bar, "", pct);
    std::fflush(stderr);
  }
  void finish(const std::string&) const override {
    if (on_) std::fprintf(stderr, "\n");
  }
  void note(const std::string& text) const override {  // kept in a log too
    std::fprintf(stderr, "%s%s\n", on_ ? "\r" : "", text.c_str());
  }
  void status(const std::string& text) const override {
    if (!on_) return;
    if (text.empty())
      std::fprintf(stderr, "\r%78s\r", "");
    else
      std::fprintf(stderr, "\r%s      ", text.c_str());
    std::fflush(stderr);
  }

 private:
  bool on_ = ::isatty(2) != 0;
};

// The program's terminal sink (one per process: it holds no state but whether stderr is a tty).
inline const ProgressSink* terminal_progress() {
  static const TerminalProgress sink;
  return &sink;
}

}  // namespace aniso
