#include "io/files.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <vector>

#include "core/error.h"

namespace fs = std::filesystem;

namespace aniso {

namespace {

std::atomic<bool> g_force{false};
std::atomic<unsigned> g_counter{0};

std::string errno_text() { return std::strerror(errno); }

// Folders being filled by write_folder_atomically, each with a trailing separator. Nobody else
// sees one until its single rename, and a failed fill discards it whole: a file inside one is
// written in place, without a temporary of its own, a rename or a scan for stale temporaries.
std::mutex g_staging_mutex;
std::vector<std::string> g_staging;

bool in_staging_folder(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_staging_mutex);
  for (const auto& s : g_staging)
    if (path.compare(0, s.size(), s) == 0 && path.find("..", s.size()) == std::string::npos)
      return true;
  return false;
}

struct StagingFolder {
  std::string prefix;
  explicit StagingFolder(const std::string& dir) : prefix(dir + "/") {
    std::lock_guard<std::mutex> lock(g_staging_mutex);
    g_staging.push_back(prefix);
  }
  ~StagingFolder() {
    std::lock_guard<std::mutex> lock(g_staging_mutex);
    g_staging.erase(std::find(g_staging.begin(), g_staging.end(), prefix));
  }
  StagingFolder(const StagingFolder&) = delete;
  StagingFolder& operator=(const StagingFolder&) = delete;
};

// Standard output, or a path under /dev or /proc (devices, /dev/stdout and its kin): written in
// place and never compared with inputs by name.
bool is_stream_path(const std::string& p) {
  return p == "-" || p.rfind("/dev/", 0) == 0 || p.rfind("/proc/", 0) == 0;
}

// The target without a trailing separator or "." (so `--out .` names the folder itself).
fs::path normal_target(const std::string& p) {
  fs::path t = fs::absolute(fs::path(p)).lexically_normal();
  while (t.filename().empty() && t.has_parent_path() && t != t.root_path()) t = t.parent_path();
  return t;
}

std::string tmp_prefix(const fs::path& target) {
  return "." + target.filename().string() + ".aniso-tmp-";
}

// ".NAME.aniso-tmp-PID-N[.ext]" beside the target.
fs::path temp_name(const fs::path& target) {
  return target.parent_path() / (tmp_prefix(target) + std::to_string(::getpid()) + "-" +
                                 std::to_string(g_counter++) + target.extension().string());
}

// Removes what killed runs left beside `target`: temporaries named after a process that no
// longer exists. Only names of our own pattern are touched.
void remove_stale_temps(const fs::path& target) {
  const std::string prefix = tmp_prefix(target);
  std::error_code ec;
  fs::directory_iterator it(target.parent_path().empty() ? "." : target.parent_path(), ec);
  if (ec) return;
  for (const auto& e : it) {
    const std::string name = e.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    if (pid <= 0 || (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH)) continue;
    fs::remove_all(e.path(), ec);
  }
}

// a (na bytes) then b (nb bytes), in as few calls as the kernel takes: one `writev`, usually.
void write_all_2(int fd, const char* a, size_t na, const char* b, size_t nb,
                 const std::string& what) {
  while (na + nb > 0) {
    iovec v[2] = {{const_cast<char*>(a), na}, {const_cast<char*>(b), nb}};
    const ssize_t w = na > 0 ? ::writev(fd, v, 2) : ::write(fd, b, nb);
    if (w < 0) {
      if (errno == EINTR) continue;
      throw Error(what + ": write failed: " + errno_text());
    }
    size_t k = static_cast<size_t>(w);
    const size_t from_a = std::min(k, na);
    a += from_a, na -= from_a, k -= from_a;
    b += k, nb -= k;
  }
}

void write_all(int fd, const char* data, size_t n, const std::string& what) {
  write_all_2(fd, nullptr, 0, data, n, what);
}

// Copies the finished temporary file into an existing special file (or stdout) in place.
void copy_in_place(const std::string& tmp, const std::string& path) {
  const int in = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) throw Error(path + ": cannot reopen the finished output: " + errno_text());
  const bool to_stdout = path == "-";
  const int out = to_stdout ? STDOUT_FILENO : ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (out < 0) {
    ::close(in);
    throw Error(path + ": cannot open for writing: " + errno_text());
  }
  char buf[1 << 16];
  try {
    for (;;) {
      const ssize_t r = ::read(in, buf, sizeof buf);
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) throw Error(path + ": cannot read back the output: " + errno_text());
      if (r == 0) break;
      write_all(out, buf, static_cast<size_t>(r), to_stdout ? "standard output" : path);
    }
  } catch (...) {
    ::close(in);
    if (!to_stdout) ::close(out);
    throw;
  }
  ::close(in);
  if (!to_stdout && ::close(out) != 0) throw Error(path + ": write failed: " + errno_text());
}

void run_writer(const std::string& tmp, const std::string& path,
                const std::function<void(const std::string&)>& write) {
  try {
    write(tmp);
    struct stat st;
    if (::stat(tmp.c_str(), &st) != 0 || !S_ISREG(st.st_mode))
      throw Error(path + ": the writer produced no file");
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
}

bool folder_is_empty(const fs::path& dir, std::string* first) {
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) throw Error(dir.string() + ": cannot list folder: " + ec.message());
  if (it == fs::directory_iterator()) return true;
  *first = it->path().filename().string();
  return false;
}

}  // namespace

void set_force_overwrite(bool force) { g_force = force; }
bool force_overwrite() { return g_force; }

void write_atomically(const std::string& path,
                      const std::function<void(const std::string&)>& write) {
  if (path.empty()) throw Error("output path is empty");
  if (in_staging_folder(path)) {
    std::error_code ec;
    fs::create_directories(fs::path(path).parent_path(), ec);
    if (ec) throw Error(path + ": cannot create its folder: " + ec.message());
    run_writer(path, path, write);  // a failure removes the file; the folder goes with the run
    return;
  }
  struct stat st;
  const bool exists = path != "-" && ::stat(path.c_str(), &st) == 0;
  const bool device_path = is_stream_path(path);
  if (exists && S_ISDIR(st.st_mode))
    throw Error(path + ": is a folder; this output is a file, give a file name");
  if (path == "-" || (exists && (!S_ISREG(st.st_mode) || device_path))) {
    // Standard output, a device, a FIFO: write in place, never rename over it.
    const fs::path tmp = fs::temp_directory_path() /
                         ("aniso-out-" + std::to_string(::getpid()) + "-" +
                          std::to_string(g_counter++) + fs::path(path).extension().string());
    run_writer(tmp.string(), path, write);
    try {
      copy_in_place(tmp.string(), path);
    } catch (...) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw;
    }
    std::error_code ec;
    fs::remove(tmp, ec);
    return;
  }
  if (!exists && fs::is_symlink(fs::symlink_status(path)))
    throw Error(path + ": is a symbolic link to nothing; give a real file name");
  // A symbolic link to a regular file: replace the file it names, keep the link.
  const fs::path target = exists ? fs::canonical(path) : normal_target(path);
  const fs::path parent = target.parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw Error(path + ": cannot create folder " + parent.string() + ": " + ec.message());
  }
  remove_stale_temps(target);
  const std::string tmp = temp_name(target).string();
  run_writer(tmp, path, write);
  if (exists) {  // keep mode and, where allowed, owner of the file it replaces
    // Best effort: a process may not give a file to another owner; the write still stands.
    (void)!::chmod(tmp.c_str(), st.st_mode & 07777);
    (void)!::chown(tmp.c_str(), st.st_uid, st.st_gid);
  }
  if (std::rename(tmp.c_str(), target.c_str()) != 0) {
    const std::string why = errno_text();
    std::error_code ec;
    fs::remove(tmp, ec);
    throw Error(path + ": cannot move the finished file into place: " + why);
  }
}

void write_file_pieces(const std::string& path,
                       const std::function<void(const ByteSink&)>& produce) {
  write_atomically(path, [&](const std::string& tmp) {
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) throw Error(path + ": cannot open for writing: " + errno_text());
    // Pieces under kHeld bytes wait and go out with the next one in one call (a file's header
    // with its first block): each call that grows a file costs the file system its own work
    // (on a journaled ext4, the inode's new size into the journal).
    constexpr size_t kHeld = size_t(64) << 10;
    std::string held;
    try {
      produce([&](const char* data, size_t size) {
        if (held.size() + size < kHeld) {
          held.append(data, size);
          return;
        }
        write_all_2(fd, held.data(), held.size(), data, size, path);
        held.clear();
      });
      write_all(fd, held.data(), held.size(), path);
    } catch (...) {
      ::close(fd);
      throw;
    }
    if (::close(fd) != 0) throw Error(path + ": write failed: " + errno_text());
  });
}

void write_text_file(const std::string& path, const std::string& text) {
  write_file_pieces(path, [&](const ByteSink& sink) { sink(text.data(), text.size()); });
}

void read_file_into(const std::string& path, size_t max_bytes, std::string* out) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) throw Error(path + ": file not found");
  if (S_ISDIR(st.st_mode)) throw Error(path + ": is a folder, expected a file");
  if (!S_ISREG(st.st_mode))
    throw Error(path + ": not a regular file (a device, FIFO or socket is not read)");
  if (static_cast<size_t>(st.st_size) > max_bytes)
    throw Error(path + ": too large (" + std::to_string(st.st_size) + " bytes; at most " +
                std::to_string(max_bytes) + ")");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open (unreadable)");
  out->resize(static_cast<size_t>(st.st_size));
  f.read(out->data(), static_cast<std::streamsize>(out->size()));
  out->resize(static_cast<size_t>(f.gcount()));
}

std::string read_text_file(const std::string& path, size_t max_bytes) {
  std::string out;
  read_file_into(path, max_bytes, &out);
  return out;
}

void check_output_folder(const std::string& dir) {
  if (dir.empty()) throw Error("output folder: empty path");
  const fs::path target = normal_target(dir);
  std::error_code ec;
  const fs::file_status ls = fs::symlink_status(target, ec);
  if (!fs::exists(ls)) return;
  const std::string hint = "; choose a new or empty folder, or pass --force to replace it";
  if (fs::is_symlink(ls)) {
    if (!force_overwrite()) throw Error(dir + ": is a symbolic link" + hint);
    return;
  }
  if (!fs::is_directory(ls)) {
    if (!force_overwrite()) throw Error(dir + ": exists and is not a folder" + hint);
    return;
  }
  std::string first;
  if (folder_is_empty(target, &first)) return;
  if (fs::exists(target / kOutputMarker)) return;
  if (!force_overwrite())
    throw Error(dir + ": folder holds files aniso did not write (e.g. '" + first + "')" + hint);
}

void write_folder_atomically(const std::string& dir,
                             const std::function<void(const std::string&)>& fill) {
  check_output_folder(dir);
  const fs::path target = normal_target(dir);
  const fs::path parent = target.parent_path();
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error(dir + ": cannot create folder " + parent.string() + ": " + ec.message());
  remove_stale_temps(target);
  const fs::path tmp = temp_name(target);
  fs::create_directory(tmp, ec);
  if (ec) throw Error(dir + ": cannot create folder: " + ec.message());
  try {
    try {
      const StagingFolder staging(tmp.string());
      fill(tmp.string());
    } catch (const Error& e) {
      throw Error(dir + ": not written (what was there is kept): " + e.what());
    }
    write_text_file((tmp / kOutputMarker).string(),
                    "{\"written_by\": \"aniso\", \"note\": \"this folder is an aniso output; "
                    "aniso may replace it\"}\n");
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
  // New: one rename. Existing: one atomic exchange, then the old content (now at tmp) goes.
  if (std::rename(tmp.c_str(), target.c_str()) == 0) return;
  if (errno != ENOTEMPTY && errno != EEXIST && errno != EISDIR && errno != ENOTDIR) {
    const std::string why = errno_text();
    fs::remove_all(tmp, ec);
    throw Error(dir + ": cannot move the finished folder into place: " + why);
  }
  if (::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) != 0) {
    // File systems without RENAME_EXCHANGE: move the old aside, the new in, then drop the old.
    const fs::path old = temp_name(target);
    if (std::rename(target.c_str(), old.c_str()) != 0 ||
        std::rename(tmp.c_str(), target.c_str()) != 0) {
      const std::string why = errno_text();
      if (!fs::exists(target)) std::rename(old.c_str(), target.c_str());
      fs::remove_all(tmp, ec);
      throw Error(dir + ": cannot move the finished folder into place: " + why);
    }
    fs::remove_all(old, ec);
    return;
  }
  fs::remove_all(tmp, ec);
}

void check_outputs_apart(const std::vector<std::string>& outputs,
                         const std::vector<std::string>& inputs) {
  auto special = [](const std::string& p) { return p.empty() || is_stream_path(p); };
  for (const auto& o : outputs) {
    if (special(o)) continue;
    std::error_code ec;
    const fs::path po = fs::weakly_canonical(normal_target(o), ec);
    if (ec) continue;
    for (const auto& i : inputs) {
      if (special(i)) continue;
      const fs::path pi = fs::weakly_canonical(normal_target(i), ec);
      if (ec) continue;
      const bool same = po == pi || fs::equivalent(po, pi, ec);
      if (same) throw Error(o + ": is an input of this command (" + i + "); choose another --out");
      // An input inside a folder the output would replace.
      const auto rel = pi.lexically_relative(po);
      if (fs::is_directory(po) && !rel.empty() && *rel.begin() != "..")
        throw Error(o + ": would replace a folder holding an input of this command (" + i +
                    "); choose another --out");
    }
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

std::string program_beside_self(const std::string& name) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  const std::string path = (self.parent_path() / name).string();
  return !ec && ::access(path.c_str(), X_OK) == 0 ? path : std::string();
}

std::string relative_to(const std::string& path, const std::string& base) {
  const fs::path p = fs::weakly_canonical(fs::absolute(path));
  const fs::path b = fs::weakly_canonical(fs::absolute(base));
  const fs::path r = p.lexically_relative(b);
  return r.empty() ? p.string() : r.string();
}

}  // namespace aniso
