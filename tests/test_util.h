// Helpers shared by the tests: a fresh temporary folder per test and running the CLI.
#pragma once
#include <gtest/gtest.h>

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
