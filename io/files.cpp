#include "io/files.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace fs = std::filesystem;

namespace aniso {

std::string temp_sibling(const std::string& path) {
  const fs::path p(path);
  const std::string name = ".tmp" + std::to_string(::getpid()) + "_" + p.filename().string();
  return (p.parent_path() / name).string();
}

void write_atomically(const std::string& path,
                      const std::function<void(const std::string&)>& write) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw Error(path + ": cannot create folder " + parent.string() + ": " + ec.message());
  }
  const std::string tmp = temp_sibling(path);
  try {
    write(tmp);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path + ": cannot write: " + ec.message());
  }
}

void write_text_file(const std::string& path, const std::string& text) {
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw Error(path + ": cannot open for writing");
    f << text;
    f.close();
    if (!f) throw Error(path + ": write failed");
  });
}

std::string read_text_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open (missing or unreadable)");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void write_folder_atomically(const std::string& dir,
                             const std::function<void(const std::string&)>& fill) {
  fs::path target = fs::absolute(fs::path(dir)).lexically_normal();
  if (target.filename().empty()) target = target.parent_path();
  const fs::path tmp = target.parent_path() /
                       (".tmp" + std::to_string(::getpid()) + "_" + target.filename().string());
  std::error_code ec;
  fs::remove_all(tmp, ec);
  fs::create_directories(tmp, ec);
  if (ec) throw Error(dir + ": cannot create folder: " + ec.message());
  try {
    fill(tmp.string());
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
  fs::remove_all(target, ec);
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove_all(tmp, ec);
    throw Error(dir + ": cannot move the finished folder into place: " + ec.message());
  }
}

std::string join_path(const std::string& dir, const std::string& rel) {
  if (rel.empty()) return dir;
  if (fs::path(rel).is_absolute()) return rel;
  return (fs::path(dir) / rel).string();
}

std::string parent_dir(const std::string& path) {
  const auto p = fs::path(path).parent_path();
  return p.empty() ? "." : p.string();
}

std::string lower_ext(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace aniso
