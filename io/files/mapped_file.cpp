#include "io/files/mapped_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <mutex>

namespace aniso {

namespace {

thread_local const MappedFile* t_reading = nullptr;  // the mappings this thread holds, innermost
struct sigaction g_before;                           // SIGBUS's action before ours

void say(const char* s) {
  for (size_t n = std::strlen(s); n > 0;) {
    const ssize_t k = ::write(2, s, n);
    if (k <= 0) return;
    s += k, n -= static_cast<size_t>(k);
  }
}

// Async-signal-safe: write(2) and _exit only. A fault inside one of the thread's mappings is its
// file's; any other goes to the action before ours.
void on_bus(int sig, siginfo_t* info, void* context) {
  for (const MappedFile* m = t_reading; m && info; m = m->outer())
    if (m->holds(info->si_addr)) {
      say("aniso: error: ");
      say(m->path().c_str());
      say(": the file got shorter while it was being read (another program is writing it?); "
          "stopped\n");
      ::_exit(1);
    }
  if (g_before.sa_flags & SA_SIGINFO) {
    if (g_before.sa_sigaction) g_before.sa_sigaction(sig, info, context);
    return;
  }
  if (g_before.sa_handler == SIG_IGN) return;
  if (g_before.sa_handler == SIG_DFL) {
    ::signal(SIGBUS, SIG_DFL);
    ::raise(SIGBUS);
    return;
  }
  g_before.sa_handler(sig);
}

void install_bus_handler() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_sigaction = on_bus;
    sa.sa_flags = SA_SIGINFO;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGBUS, &sa, &g_before);
  });
}

}  // namespace

MappedFile::MappedFile(const std::string& path, size_t size) : path_(path) {
  if (size == 0) return;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  struct stat st;
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && static_cast<size_t>(st.st_size) == size) {
    install_bus_handler();
    void* p = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (p != MAP_FAILED) bytes_ = std::string_view(static_cast<const char*>(p), size);
  }
  ::close(fd);
  if (bytes_.empty()) return;
  outer_ = t_reading;
  t_reading = this;
}

MappedFile::~MappedFile() {
  if (bytes_.empty()) return;
  t_reading = outer_;
  ::munmap(const_cast<char*>(bytes_.data()), bytes_.size());
}

}  // namespace aniso
