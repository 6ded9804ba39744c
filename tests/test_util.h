// Helpers shared by the tests: a fresh temporary folder per test and running the CLI.
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
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

// Runs a shell command line, collecting stdout and stderr together.
inline RunResult run_command(const std::string& cmd) {
  RunResult r;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

inline RunResult run_cli(const std::string& args) {
  return run_command(std::string(ANISO_BIN) + " " + args);
}

// A shell prefix bounding a command's address space to `kb` KiB: a memory test's guard. Empty in
// an AddressSanitizer build, whose shadow memory reserves terabytes of address space up front.
inline std::string memory_limit(long kb) {
#if defined(__SANITIZE_ADDRESS__)
  (void)kb;
  return "";
#else
  return "ulimit -v " + std::to_string(kb) + "; ";
#endif
}

// The map file of `key` ("kd", "n_sigma", "determined", "topology_s", ...) that the material at
// PREFIX.json names: fit --maps and merge write them beside it as PREFIX_KEY.GEN.exr, one
// generation per run (io/files/files.h write_generation). PREFIX_KEY.exr (absent) if it names none.
inline std::string map_of(const std::string& prefix, const std::string& key) {
  const std::filesystem::path p(prefix);
  const std::string start = p.filename().string() + "_" + key + ".";
  std::ifstream in(prefix + ".json");
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_object())
    for (const char* block : {"maps", "maps_uncertainty", "topology"})
      if (j.contains(block) && j[block].is_object())
        for (const auto& [k, v] : j[block].items())
          if (v.is_string() && v.get<std::string>().rfind(start, 0) == 0)
            return (p.parent_path() / v.get<std::string>()).string();
  return prefix + "_" + key + ".exr";
}

}  // namespace aniso::test

namespace aniso::test {

// Runs a shell command line; "$A" in it is the aniso binary.
inline RunResult sh(const std::string& script) {
  const std::string cmd = "A='" + std::string(ANISO_BIN) + "'\n" + script + "\n";
  // Through a script file, so the command line needs no quoting.
  const std::string file = std::string(ANISO_TEST_TMP) + "/sh_" + std::to_string(::getpid()) + "_" +
                           std::to_string(reinterpret_cast<uintptr_t>(&script)) + ".sh";
  {
    FILE* f = std::fopen(file.c_str(), "w");
    std::fputs(cmd.c_str(), f);
    std::fclose(f);
  }
  RunResult r = run_command("bash " + file);
  std::remove(file.c_str());
  return r;
}

// Rewrites a JSON file through `f` (to break a valid capture or material in one place).
inline void edit_json(const std::string& file, const std::function<void(nlohmann::json&)>& f) {
  std::ifstream in(file);
  nlohmann::json j = nlohmann::json::parse(in);
  in.close();
  f(j);
  std::ofstream(file) << j.dump();
}

}  // namespace aniso::test
