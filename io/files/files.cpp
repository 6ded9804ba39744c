#include "io/files/files.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "core/error.h"

namespace fs = std::filesystem;

namespace aniso {

namespace {

std::atomic<unsigned> g_counter{0};

// A folder being filled holds this file until its swap: a stale temporary folder that has it is
// a killed run's partial output, removed whole; one without it holds an earlier output (or a
// finished one), cleaned by the marker's rule.
constexpr const char* kStagingSentinel = ".aniso-staging";

// Outputs claimed by check_output_file and check_output_folder: absolute normal path -> what was
// claimed. A claim's `force` is that output's own: another output of the same run keeps its own.
struct Claim {
  OutputKind kind;
  bool force = false;
};
std::mutex g_claims_mutex;
std::map<std::string, Claim> g_claims;         // files
std::map<std::string, Claim> g_folder_claims;  // folders

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

fs::path prune_output(const fs::path& old, const fs::path& target, const char* kind);

// Removes what killed runs left beside `target`: temporaries named after a process that no
// longer exists. Only names of our own pattern are touched; a folder among them that is not a
// partial output is cleaned as an earlier output is (prune_output): nothing of a person's goes.
void remove_stale_temps(const fs::path& target, const char* kind = nullptr) {
  const std::string prefix = tmp_prefix(target);
  std::error_code ec;
  fs::directory_iterator it(target.parent_path().empty() ? "." : target.parent_path(), ec);
  if (ec) return;
  std::vector<fs::path> stale;
  for (const auto& e : it) {
    const std::string name = e.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    if (pid <= 0 || (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH)) continue;
    stale.push_back(e.path());
  }
  for (const auto& p : stale) {
    const fs::file_status st = fs::symlink_status(p, ec);
    if (fs::is_directory(st) && !fs::exists(fs::symlink_status(p / kStagingSentinel, ec))) {
      const fs::path aside = prune_output(p, target, kind);
      if (!aside.empty())
        std::fprintf(stderr, "note: %s: a killed run left files aniso did not write; moved to %s\n",
                     target.string().c_str(), aside.string().c_str());
    } else {
      fs::remove_all(p, ec);
    }
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

// ---- folder outputs: the marker, the state of a target, cleaning an earlier output ----------

struct FileRecord {
  uint64_t size = 0;
  int64_t mtime_ns = 0;
  // The same file as recorded: a file rewritten or edited since changes one or the other.
  bool operator==(const FileRecord& o) const { return size == o.size && mtime_ns == o.mtime_ns; }
};

int64_t mtime_ns(const struct stat& st) {
  return static_cast<int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

// Every file (and symbolic link, and other non-folder) under `dir`, by path relative to it; the
// marker and the staging sentinel at the top are left out.
std::map<std::string, FileRecord> walk_files(const fs::path& dir) {
  std::map<std::string, FileRecord> out;
  std::error_code ec;
  fs::recursive_directory_iterator it(dir, fs::directory_options::none, ec), end;
  if (ec) throw Error(dir.string() + ": cannot list folder: " + ec.message());
  for (; it != end; it.increment(ec)) {
    if (ec) {
      if (ec == std::errc::no_such_file_or_directory) break;  // swapped out while listed
      throw Error(dir.string() + ": cannot list folder: " + ec.message());
    }
    const fs::path& p = it->path();
    struct stat st;
    if (::lstat(p.c_str(), &st) != 0) continue;  // gone meanwhile
    if (S_ISDIR(st.st_mode)) continue;
    const std::string rel = p.lexically_relative(dir).generic_string();
    if (rel == kOutputMarker || rel == kStagingSentinel) continue;
    out[rel] = {static_cast<uint64_t>(st.st_size), mtime_ns(st)};
  }
  return out;
}

struct Marker {
  bool present = false, readable = false;
  std::string kind;
  std::map<std::string, FileRecord> files;
};

Marker read_marker(const fs::path& dir) {
  Marker m;
  const fs::path p = dir / kOutputMarker;
  struct stat st;
  if (::lstat(p.c_str(), &st) != 0) return m;
  m.present = true;
  if (!S_ISREG(st.st_mode) || st.st_size > (int64_t(64) << 20)) return m;
  try {
    std::ifstream f(p, std::ios::binary);
    const nlohmann::json j = nlohmann::json::parse(f);
    if (!j.is_object() || !j.contains("kind") || !j["kind"].is_string() || !j.contains("files") ||
        !j["files"].is_array())
      return m;
    m.kind = j["kind"].get<std::string>();
    for (const auto& e : j["files"]) {
      if (!e.is_array() || e.size() != 3 || !e[0].is_string()) return m;
      m.files[e[0].get<std::string>()] = {e[1].get<uint64_t>(), e[2].get<int64_t>()};
    }
    m.readable = true;
  } catch (const std::exception&) {
  }
  return m;
}

void write_marker(const fs::path& dir, OutputKind kind) {
  nlohmann::json files = nlohmann::json::array();
  for (const auto& [rel, r] : walk_files(dir)) files.push_back({rel, r.size, r.mtime_ns});
  const nlohmann::json j = {
      {"written_by", "aniso"},
      {"kind", kind_name(kind)},
      {"files", files},
      {"note",
       "this folder is an aniso output; aniso replaces it only while it holds exactly these files "
       "(path, size, modification time in ns), and never deletes anything else"}};
  write_text_file((dir / kOutputMarker).string(), j.dump(1) + "\n");
}

// What a folder output would replace at `target`: nothing, or an earlier output of its own kind
// that holds what it recorded (replaceable); anything else, with the reason naming a file.
struct FolderState {
  enum What { kAbsent, kEmpty, kOwn, kOther } what = kAbsent;
  bool is_folder = true;
  std::string why;
};

FolderState folder_state_once(const fs::path& target, OutputKind kind);

std::string marker_text(const fs::path& dir) {
  std::ifstream f(dir / kOutputMarker, std::ios::binary);
  std::string t((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return t;
}

// Another run of the same output may swap its folder in while this one looks: a marker that
// changed during the look means the look saw a mix, and it is taken again.
FolderState folder_state(const fs::path& target, OutputKind kind) {
  FolderState s;
  for (int attempt = 0; attempt < 20; ++attempt) {
    const std::string before = marker_text(target);
    s = folder_state_once(target, kind);
    if (s.what != FolderState::kOther || marker_text(target) == before) return s;
  }
  return s;
}

FolderState folder_state_once(const fs::path& target, OutputKind kind) {
  FolderState s;
  std::error_code ec;
  const fs::file_status ls = fs::symlink_status(target, ec);
  if (!fs::exists(ls)) return s;
  s.what = FolderState::kOther;
  if (fs::is_symlink(ls) || !fs::is_directory(ls)) {
    s.is_folder = false;
    s.why = fs::is_symlink(ls) ? "is a symbolic link" : "exists and is not a folder";
    return s;
  }
  std::string first;
  if (folder_is_empty(target, &first)) {
    s.what = FolderState::kEmpty;
    return s;
  }
  const Marker m = read_marker(target);
  if (!m.present) {
    s.why = "holds files aniso did not write (e.g. '" + first + "')";
    return s;
  }
  if (!m.readable) {
    s.why = "was written by an earlier aniso that did not record its files (" +
            std::string(kOutputMarker) + ")";
    return s;
  }
  if (m.kind != kind_name(kind)) {
    s.why = "is an aniso " + m.kind + " output, not a " + kind_name(kind) + " output";
    return s;
  }
  if (kind == OutputKind::kBenchWork) {  // the bench's own folder: its content is the bench's
    s.what = FolderState::kOwn;
    return s;
  }
  for (const auto& [rel, r] : walk_files(target)) {
    const auto it = m.files.find(rel);
    if (it == m.files.end()) {
      s.why = "holds '" + rel + "', which aniso did not write";
      return s;
    }
    if (!(it->second == r)) {
      s.why = "holds '" + rel + "', changed since aniso wrote it";
      return s;
    }
  }
  s.what = FolderState::kOwn;
  return s;
}

// A free name beside `target` for what is moved aside: NAME.aniso-old-N (folders), or
// STEM.aniso-old-N.EXT (files, which keep their extension so they still open). `tag` is "old",
// or "new" for a finished output that could not be put in place.
fs::path aside_name(const fs::path& target, bool folder, const std::string& tag, int n) {
  const std::string suffix = ".aniso-" + tag + "-" + std::to_string(n);
  if (folder || target.extension().empty())
    return target.parent_path() / (target.filename().string() + suffix);
  return target.parent_path() / (target.stem().string() + suffix + target.extension().string());
}

// Moves `from` to a free aside name of `target` without ever replacing anything there.
fs::path move_aside(const fs::path& from, const fs::path& target, bool folder,
                    const std::string& tag) {
  for (int n = 1; n < 100000; ++n) {
    const fs::path to = aside_name(target, folder, tag, n);
    if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0) return to;
    if (errno == EEXIST) continue;
    if (errno == EINVAL || errno == ENOSYS) {  // no RENAME_NOREPLACE here: check, then rename
      std::error_code ec;
      if (fs::exists(fs::symlink_status(to, ec))) continue;
      if (std::rename(from.c_str(), to.c_str()) == 0) return to;
    }
    throw Error(target.string() + ": cannot move " + from.string() + " aside: " + errno_text());
  }
  throw Error(target.string() + ": no free name to move " + from.string() + " aside");
}

// Cleans an earlier output at `old` (a folder that is no longer in place): where it is an output of
// `kind`, the files its marker records, unchanged, are deleted, then the folders they leave empty.
// Anything else (an output of another kind: all of it) is moved aside beside `target` whole; its
// new path is returned ("" when nothing was left).
fs::path prune_output(const fs::path& old, const fs::path& target, const char* kind) {
  std::error_code ec;
  const Marker m = read_marker(old);
  if (m.readable && kind && m.kind == kind) {
    for (const auto& [rel, r] : walk_files(old)) {
      const auto it = m.files.find(rel);
      if (it != m.files.end() && it->second == r) fs::remove(old / rel, ec);
    }
    fs::remove(old / kOutputMarker, ec);
  }
  fs::remove(old / kStagingSentinel, ec);
  // Empty folders, deepest first.
  std::vector<fs::path> dirs;
  for (fs::recursive_directory_iterator it(old, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_directory(ec) && !it->is_symlink(ec)) dirs.push_back(it->path());
  std::sort(dirs.begin(), dirs.end(),
            [](const fs::path& a, const fs::path& b) { return a.string() > b.string(); });
  for (const auto& d : dirs) fs::remove(d, ec);  // only empty ones go
  if (fs::remove(old, ec)) return {};
  return move_aside(old, target, true, "old");
}

// The nearest folder at or above `p` that exists must be one this process may write in (the
// rest is created): checked before a long run, so the work is not lost at the end.
void check_writable_place(const fs::path& target, const std::string& shown) {
  fs::path p = target.parent_path();
  std::error_code ec;
  while (!p.empty() && !fs::exists(fs::symlink_status(p, ec)) && p != p.root_path())
    p = p.parent_path();
  if (p.empty()) p = ".";
  if (!fs::is_directory(p, ec))
    throw Error(shown + ": cannot be written: " + p.string() + " is not a folder");
  if (::access(p.c_str(), W_OK | X_OK) != 0)
    throw Error(shown + ": cannot be written: no permission to write in " + p.string() +
                " (checked before any work)");
}

bool valid_utf8(const std::string& s) {
  for (size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    const int n = c < 0x80 ? 0 : (c >> 5) == 6 ? 1 : (c >> 4) == 14 ? 2 : (c >> 3) == 30 ? 3 : -1;
    if (n < 0 || i + n >= s.size() + (n == 0)) return false;
    for (int k = 1; k <= n; ++k)
      if ((static_cast<unsigned char>(s[i + k]) >> 6) != 2) return false;
    i += n + 1;
  }
  return true;
}

// Outputs record paths in JSON, which holds UTF-8 only: a path that is not is named before work.
void check_utf8_path(const fs::path& target, const std::string& shown) {
  if (!valid_utf8(target.string()))
    throw Error(shown +
                ": the path is not valid UTF-8, and aniso records paths in JSON (UTF-8 "
                "only); rename the file or folder, or choose another --out");
}

std::string force_hint(const fs::path& target, bool folder) {
  return "; choose another " + std::string(folder ? "folder" : "name") +
         ", or pass --force to move it aside to " + aside_name(target, folder, "old", 1).string() +
         " (or the next free number) and write there: nothing is deleted";
}

// `path` relative to `base`, which is already resolved (weakly_canonical of an absolute path);
// `path` itself where it has no relative form.
std::string relative_to_resolved(const std::string& path, const fs::path& base) {
  const fs::path p = fs::weakly_canonical(fs::absolute(path));
  const fs::path r = p.lexically_relative(base);
  return r.empty() ? p.string() : r.string();
}

std::optional<Claim> file_claim(const std::string& path) {
  if (path.empty() || is_stream_path(path)) return std::nullopt;
  const std::string key = normal_target(path).string();
  std::lock_guard<std::mutex> lock(g_claims_mutex);
  const auto it = g_claims.find(key);
  if (it == g_claims.end()) return std::nullopt;
  return it->second;
}

std::optional<OutputKind> claimed_kind(const std::string& path) {
  const auto c = file_claim(path);
  return c ? std::optional<OutputKind>(c->kind) : std::nullopt;
}

// Whether the folder output `target` was claimed with force (by the command, before the library
// that writes it checks it again without knowing the flag).
bool folder_force(const fs::path& target) {
  std::lock_guard<std::mutex> lock(g_claims_mutex);
  const auto it = g_folder_claims.find(target.string());
  return it != g_folder_claims.end() && it->second.force;
}

// Why an existing regular file may not be replaced by a file output of `kind` ("" if it may).
std::string file_refusal(const std::string& path, OutputKind kind) {
  const std::string k = stamped_kind(path);
  if (stamped(kind) && k == kind_name(kind)) return "";
  if (kind == OutputKind::kTable)
    return "exists (a table carries no mark of who wrote it, so aniso never replaces one)";
  if (kind == OutputKind::kShoot) return "exists (it may hold your measurements)";
  if (k.empty() || k == "aniso")
    return "exists and was not written by aniso as a " + std::string(kind_name(kind));
  return "is an aniso " + k + ", not a " + kind_name(kind);
}

}  // namespace

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
  if (const auto claim = file_claim(path);
      claim && ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) {
    // Checked before the work; again now, as the file may have come or changed meanwhile.
    const std::string why = file_refusal(path, claim->kind);
    if (!why.empty() && !claim->force) {
      const fs::path kept = move_aside(tmp, target, false, "new");
      throw Error(path + ": " + why + "; it was not replaced, and this run's output is at " +
                  kept.string());
    }
    if (!why.empty()) {
      // --force: the old file keeps its inode under a free name (a hard link: the target is never
      // missing), then the new one is renamed over the target.
      for (int n = 1;; ++n) {
        const fs::path aside = aside_name(target, false, "old", n);
        if (::link(target.c_str(), aside.c_str()) == 0) {
          std::fprintf(stderr, "note: %s: %s; moved to %s (--force)\n", path.c_str(), why.c_str(),
                       aside.string().c_str());
          break;
        }
        if (errno != EEXIST || n > 100000) {
          const std::string e = errno_text();
          std::error_code ec;
          fs::remove(tmp, ec);
          throw Error(path + ": cannot move the earlier file aside: " + e);
        }
      }
    }
  }
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

const char* kind_name(OutputKind kind) {
  switch (kind) {
    case OutputKind::kCapture:
      return "capture";
    case OutputKind::kImportedCapture:
      return "imported-capture";
    case OutputKind::kPhotoShoot:
      return "photo-shoot";
    case OutputKind::kBake:
      return "bake";
    case OutputKind::kExport:
      return "export";
    case OutputKind::kResiduals:
      return "residuals";
    case OutputKind::kBenchWork:
      return "bench-work";
    case OutputKind::kMaterial:
      return "material";
    case OutputKind::kMapsTile:
      return "maps-tile";
    case OutputKind::kTable:
      return "table";
    case OutputKind::kShoot:
      return "shoot";
    case OutputKind::kPreview:
      return "preview";
    case OutputKind::kBoard:
      return "board";
    case OutputKind::kScreenshot:
      return "screenshot";
    case OutputKind::kBenchResult:
      return "bench-result";
    case OutputKind::kText:
      return "text";
  }
  return "output";
}

bool stamped(OutputKind kind) { return kind != OutputKind::kTable && kind != OutputKind::kShoot; }

std::string json_stamp(const std::string& path) {
  const auto k = claimed_kind(path);
  return k && stamped(*k) ? std::string("aniso ") + kind_name(*k) : std::string();
}

std::string output_stamp(const std::string& path) {
  const auto k = claimed_kind(path);
  return k ? std::string("aniso ") + kind_name(*k) : std::string("aniso");
}

std::string stamped_kind(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return "";
  std::ifstream f(path, std::ios::binary);
  if (!f) return "";
  // The stamp is near the start (images' headers) or the end (a JSON object's last key).
  constexpr size_t kPart = size_t(64) << 10;
  const auto size = static_cast<size_t>(st.st_size);
  std::string text(std::min(size, 2 * kPart), '\0');
  if (size <= 2 * kPart) {
    f.read(text.data(), static_cast<std::streamsize>(size));
  } else {
    f.read(text.data(), kPart);
    f.seekg(static_cast<std::streamoff>(size - kPart));
    f.read(text.data() + kPart, kPart);
  }
  auto kind_after = [&](size_t at) -> std::string {  // at: just past "aniso"
    if (at >= text.size() || text[at] != ' ') return "aniso";
    std::string k;
    for (size_t i = at + 1; i < text.size() && k.size() < 32; ++i) {
      const char c = text[i];
      if ((c >= 'a' && c <= 'z') || c == '-')
        k += c;
      else
        break;
    }
    return k.empty() ? "aniso" : k;
  };
  using namespace std::string_literals;
  // JSON key, PNG tEXt "Software", EXR string attribute "software", JPEG comment segment.
  for (const std::string& lead : {"\"written_by\": \"aniso"s, "Software\0aniso"s}) {
    const size_t at = text.rfind(lead);
    if (at != std::string::npos) return kind_after(at + lead.size());
  }
  auto aniso_at = [&](size_t at) {
    return at + 5 <= text.size() && text.compare(at, 5, "aniso") == 0;
  };
  const std::string exr = "software\0string\0"s;
  if (const size_t at = text.find(exr); at != std::string::npos && aniso_at(at + exr.size() + 4))
    return kind_after(at + exr.size() + 9);
  if (text.compare(0, 2, "\xFF\xD8") == 0)
    for (size_t at = text.find("\xFF\xFE"); at != std::string::npos;
         at = text.find("\xFF\xFE", at + 2))
      if (aniso_at(at + 4)) return kind_after(at + 9);
  return "";
}

void check_output_folder(const std::string& dir, OutputKind kind, bool force) {
  if (dir.empty()) throw Error("output folder: empty path");
  const fs::path target = normal_target(dir);
  check_utf8_path(target, dir);
  check_writable_place(target, dir);
  force = force || folder_force(target);
  const FolderState s = folder_state(target, kind);
  if (s.what == FolderState::kOther && !force)
    throw Error(dir + ": " + s.why + force_hint(target, s.is_folder));
  std::lock_guard<std::mutex> lock(g_claims_mutex);
  g_folder_claims[target.string()] = Claim{kind, force};
}

void mark_folder(const std::string& dir, OutputKind kind) { write_marker(dir, kind); }

void check_output_file(const std::string& path, OutputKind kind, bool force) {
  if (path.empty()) throw Error("output path is empty");
  if (is_stream_path(path)) return;
  struct stat st;
  const bool exists = ::stat(path.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode))
    throw Error(path + ": is a folder; this output is a file, give a file name");
  const fs::path target = normal_target(path);
  check_utf8_path(target, path);
  check_writable_place(exists ? fs::canonical(path) : target, path);
  if (const auto earlier = file_claim(path)) force = force || earlier->force;
  if (exists && S_ISREG(st.st_mode) && !force) {
    const std::string why = file_refusal(path, kind);
    if (!why.empty()) throw Error(path + ": " + why + force_hint(target, false));
  }
  std::lock_guard<std::mutex> lock(g_claims_mutex);
  g_claims[target.string()] = Claim{kind, force};
}

void write_folder_atomically(const std::string& dir, OutputKind kind,
                             const std::function<void(const std::string&)>& fill) {
  check_output_folder(dir, kind);
  const fs::path target = normal_target(dir);
  const fs::path parent = target.parent_path();
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error(dir + ": cannot create folder " + parent.string() + ": " + ec.message());
  remove_stale_temps(target, kind_name(kind));
  const fs::path tmp = temp_name(target);
  fs::create_directory(tmp, ec);
  if (ec) throw Error(dir + ": cannot create folder: " + ec.message());
  try {
    write_text_file((tmp / kStagingSentinel).string(), "");
    try {
      const StagingFolder staging(tmp.string());
      fill(tmp.string());
    } catch (const Error& e) {
      // Name files by where they were to be, not by the private folder they were written in.
      std::string what = e.what();
      for (size_t at = what.find(tmp.string()); at != std::string::npos;
           at = what.find(tmp.string(), at + target.string().size()))
        what.replace(at, tmp.string().size(), target.string());
      throw Error(dir + ": not written (what was there is kept): " + what);
    }
    write_marker(tmp, kind);
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
  // What is there now (a person may have added a file while this ran): the same rule as before
  // the work; a finished output that may not go in is kept beside it, not thrown away.
  const FolderState s = folder_state(target, kind);
  fs::remove(tmp / kStagingSentinel, ec);
  if (s.what == FolderState::kOther && !folder_force(target)) {
    const fs::path kept = move_aside(tmp, target, true, "new");
    throw Error(dir + ": " + s.why + "; nothing there was replaced, and this run's output is at " +
                kept.string());
  }
  if (s.what == FolderState::kOther && !s.is_folder) {  // --force over a file or a link
    const fs::path aside = move_aside(target, target, false, "old");
    std::fprintf(stderr, "note: %s: %s; moved to %s (--force)\n", dir.c_str(), s.why.c_str(),
                 aside.string().c_str());
  }
  // New: one rename. Existing: one atomic exchange, then the old content (now at tmp) is cleaned:
  // its recorded files go, anything else is moved aside.
  if (std::rename(tmp.c_str(), target.c_str()) == 0) return;
  if (errno != ENOTEMPTY && errno != EEXIST && errno != EISDIR && errno != ENOTDIR) {
    const std::string why = errno_text();
    fs::remove_all(tmp, ec);
    throw Error(dir + ": cannot move the finished folder into place: " + why);
  }
  fs::path old = tmp;
  if (::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) != 0) {
    // File systems without RENAME_EXCHANGE: move the old aside, the new in.
    old = temp_name(target);
    if (std::rename(target.c_str(), old.c_str()) != 0 ||
        std::rename(tmp.c_str(), target.c_str()) != 0) {
      const std::string why = errno_text();
      if (!fs::exists(target)) std::rename(old.c_str(), target.c_str());
      fs::remove_all(tmp, ec);
      throw Error(dir + ": cannot move the finished folder into place: " + why);
    }
  }
  const fs::path aside = prune_output(old, target, kind_name(kind));
  if (!aside.empty())
    std::fprintf(stderr,
                 "note: %s: what was there (it %s) is now at %s (--force): nothing deleted\n",
                 dir.c_str(), s.why.empty() ? "held files aniso did not write" : s.why.c_str(),
                 aside.string().c_str());
}

namespace {
// A 64-bit hash of bytes, 8 at a time (names a generation; not a checksum against attack).
uint64_t hash_bytes(const std::string& b, uint64_t h) {
  size_t i = 0;
  for (; i + 8 <= b.size(); i += 8) {
    uint64_t w;
    std::memcpy(&w, b.data() + i, 8);
    h = (h ^ w) * 0x100000001b3ULL;
    h ^= h >> 29;
  }
  for (; i < b.size(); ++i) h = (h ^ static_cast<unsigned char>(b[i])) * 0x100000001b3ULL;
  return h;
}
}  // namespace

std::map<std::string, std::string> write_generation(
    const std::string& owner, const std::function<void(const std::string&)>& fill) {
  const fs::path target = normal_target(owner);
  const fs::path parent = target.parent_path();
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error(owner + ": cannot create folder " + parent.string() + ": " + ec.message());
  remove_stale_temps(target);
  const fs::path tmp = temp_name(target);
  fs::create_directory(tmp, ec);
  if (ec) throw Error(owner + ": cannot create a folder beside it: " + ec.message());
  std::map<std::string, std::string> names;
  try {
    write_text_file((tmp / kStagingSentinel).string(), "");
    {
      const StagingFolder staging(tmp.string());
      fill(tmp.string());
    }
    const auto files = walk_files(tmp);
    uint64_t h = 0xcbf29ce484222325ULL;
    std::string bytes;
    for (const auto& [rel, r] : files) {
      read_file_into((tmp / rel).string(), size_t(1) << 40, &bytes);
      h = hash_bytes(rel, h);
      h = hash_bytes(bytes, h);
    }
    char gen[17];
    std::snprintf(gen, sizeof gen, "%08llx", static_cast<unsigned long long>(h >> 32));
    for (const auto& [rel, r] : files) {
      const fs::path plain(rel);
      if (plain.has_parent_path()) throw Error(owner + ": a generation's files are flat");
      const std::string name = plain.stem().string() + "." + gen + plain.extension().string();
      const fs::path to = parent / name;
      if (::renameat2(AT_FDCWD, (tmp / rel).c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) != 0) {
        if (errno != EEXIST) throw Error(to.string() + ": cannot move into place: " + errno_text());
        // The same name: the same bytes (an earlier run of the same result), or someone's file.
        if (read_text_file(to.string(), size_t(1) << 40) !=
            read_text_file((tmp / rel).string(), size_t(1) << 40))
          throw Error(to.string() + ": exists and holds other bytes than this run's; move it");
      }
      names[rel] = name;
    }
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
  fs::remove_all(tmp, ec);
  return names;
}

std::string text_fingerprint(const std::string& text) {
  char out[17];
  std::snprintf(out, sizeof out, "%016llx",
                static_cast<unsigned long long>(hash_bytes(text, 0xcbf29ce484222325ULL)));
  return out;
}

std::string files_fingerprint(const std::vector<std::string>& files, const std::string& base) {
  std::string all;
  constexpr size_t kPart = size_t(64) << 10;
  // A capture lists its shared geometry once per view: each file is resolved and read once, its
  // piece reused where it repeats (the same bytes as reading it again). The base is resolved once.
  const fs::path b = fs::weakly_canonical(fs::absolute(base));
  std::map<std::string, std::pair<std::string, bool>> pieces;  // file -> its bytes, regular
  for (const auto& f : files) {
    auto [it, fresh] = pieces.try_emplace(f);
    std::string& piece = it->second.first;
    bool& regular = it->second.second;
    if (fresh) {
      piece = relative_to_resolved(f, b);
      piece.push_back('\0');
      struct stat st;
      regular = ::stat(f.c_str(), &st) == 0 && S_ISREG(st.st_mode);
      if (regular) {
        piece += std::to_string(st.st_size);
        std::ifstream in(f, std::ios::binary);
        std::string part(std::min<size_t>(kPart, static_cast<size_t>(st.st_size)), '\0');
        in.read(part.data(), static_cast<std::streamsize>(part.size()));
        piece += part;
        if (static_cast<size_t>(st.st_size) > kPart) {
          in.seekg(-static_cast<std::streamoff>(part.size()), std::ios::end);
          in.read(part.data(), static_cast<std::streamsize>(part.size()));
          piece += part;
        }
      }
    }
    all += piece;
    if (!regular) continue;        // its name alone
    all += text_fingerprint(all);  // keeps `all` from growing past a few MB per file set
    all.erase(0, all.size() - 16);
  }
  return text_fingerprint(all);
}

bool is_generation_name(const std::string& name) {
  const fs::path p(name);
  const std::string stem = p.stem().string();  // "m_kd.1f3a9c07"
  const size_t dot = stem.rfind('.');
  if (dot == std::string::npos || stem.size() - dot != 9 || p.has_parent_path()) return false;
  for (size_t i = dot + 1; i < stem.size(); ++i)
    if (!std::isxdigit(static_cast<unsigned char>(stem[i]))) return false;
  return dot > 0;
}

void remove_generation(const std::string& owner, const std::vector<std::string>& names,
                       const std::vector<std::string>& keep) {
  const fs::path parent = normal_target(owner).parent_path();
  for (const auto& n : names) {
    if (!is_generation_name(n) || std::find(keep.begin(), keep.end(), n) != keep.end()) continue;
    const fs::path p = parent / n;
    const std::string ext = lower_ext(n);
    if ((ext != ".exr" && ext != ".png") || stamped_kind(p.string()).empty()) continue;
    std::error_code ec;
    fs::remove(p, ec);
  }
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
  return relative_to_resolved(path, fs::weakly_canonical(fs::absolute(base)));
}

}  // namespace aniso
