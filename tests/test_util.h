// Helpers shared by the tests: a fresh temporary folder per test and running the CLI.
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

namespace aniso::test {

inline std::string tmp_dir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string dir =
      std::string(ANISO_TEST_TMP) + "/" + info->test_suite_name() + "." + info->name() + "/" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

struct RunResult {
  int status = -1;
  std::string output;  // stdout and stderr
};

inline RunResult run_cli(const std::string& args) {
  RunResult r;
  const std::string cmd = std::string(ANISO_BIN) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

}  // namespace aniso::test

namespace aniso::test {

// Runs a shell command line; "$A" in it is the aniso binary.
inline RunResult sh(const std::string& script) {
  RunResult r;
  const std::string cmd = "A='" + std::string(ANISO_BIN) + "'\n" + script + "\n";
  // Through a script file, so the command line needs no quoting.
  const std::string file = std::string(ANISO_TEST_TMP) + "/sh_" + std::to_string(::getpid()) + "_" +
                           std::to_string(reinterpret_cast<uintptr_t>(&r)) + ".sh";
  {
    FILE* f = std::fopen(file.c_str(), "w");
    std::fputs(cmd.c_str(), f);
    std::fclose(f);
  }
  FILE* q = popen(("bash " + file + " 2>&1").c_str(), "r");
  if (!q) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, q)) > 0) r.output.append(buf, n);
  const int st = pclose(q);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  std::remove(file.c_str());
  return r;
}

}  // namespace aniso::test
