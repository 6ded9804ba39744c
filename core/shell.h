// Running another program through the shell: its exit status and everything it printed (stdout
// and stderr together), and a string quoted as one word for that shell.
#pragma once
#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace aniso {

// `s` as one single-quoted shell word (a ' inside closes, escapes and reopens the quote).
inline std::string shell_quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `cmd` with /bin/sh, its stderr joined to stdout, appending what it printed to *out; its
// exit status, or -1 where it could not start or did not exit.
inline int run_shell(const std::string& cmd, std::string* out) {
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out->append(buf, n);
  const int st = ::pclose(p);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

}  // namespace aniso
