// Files and folders the tool writes, and the rules that keep a person's files safe (issue 8):
//
//  - A file output is written to a temporary sibling and renamed over the target in one step, so
//    a failed or killed run leaves the previous file as it was. A replaced file keeps its mode
//    (and its owner where the process may set it). Every write is checked.
//  - "-" means standard output. A target that exists and is not a regular file (a device, a FIFO,
//    the pipe behind /dev/stdout) is written in place, never renamed over. A folder is refused.
//  - A folder output is written beside the target and swapped in with one atomic exchange
//    (renameat2 RENAME_EXCHANGE). It is written only if it does not exist, is empty, or holds the
//    marker file of an earlier aniso output; anything else is refused unless `force` is set.
//  - Temporary files and folders of killed runs (named after their dead process) are removed by
//    the next run that writes the same target.
//  - An output never replaces an input of the same command (check_outputs_apart).
#pragma once
#include <functional>
#include <string>
#include <vector>

namespace aniso {

// The marker file inside every folder this tool writes.
inline constexpr const char* kOutputMarker = ".aniso-output";

// Process-wide: may a folder output replace a folder holding files aniso did not write? Set
// once by the CLI from `--force`; off by default.
void set_force_overwrite(bool force);
bool force_overwrite();

// Calls write(tmp) and moves the result to `path` (see the rules above); removes tmp and
// rethrows if write throws. `write` must write a file at exactly the path it is given.
void write_atomically(const std::string& path,
                      const std::function<void(const std::string&)>& write);

void write_text_file(const std::string& path, const std::string& text);

// Receives a file's bytes in order, piece by piece.
using ByteSink = std::function<void(const char* data, size_t size)>;
// Writes `path` atomically from the pieces `produce` hands its sink, each as it comes: nothing the
// size of the file is held in memory.
void write_file_pieces(const std::string& path,
                       const std::function<void(const ByteSink&)>& produce);

// Reads a regular file of at most `max_bytes` (default 256 MiB); anything else (missing, a
// folder, a device, a FIFO, too large) is an error naming the file.
std::string read_text_file(const std::string& path, size_t max_bytes = size_t(256) << 20);
// The same into *out, whose allocation is kept where it is large enough (a buffer reused file
// after file touches no fresh pages).
void read_file_into(const std::string& path, size_t max_bytes, std::string* out);

// Throws unless `dir` may be (re)written by a folder output: it does not exist, is an empty
// folder, or holds kOutputMarker; with force_overwrite() any folder. Call it before a long run.
void check_output_folder(const std::string& dir);

// Writes a whole folder: fill(tmp_dir), then the marker, then one atomic swap into place. While
// fill runs, files written under tmp_dir go straight to their names (the folder is private and
// is discarded whole if fill fails): no per-file temporary and rename.
void write_folder_atomically(const std::string& dir,
                             const std::function<void(const std::string&)>& fill);

// Throws if an output (a file, or a folder that would be replaced) is, or contains, one of the
// inputs: "OUT: is an input of this command (IN); choose another --out".
void check_outputs_apart(const std::vector<std::string>& outputs,
                         const std::vector<std::string>& inputs);

std::string join_path(const std::string& dir, const std::string& rel);
std::string parent_dir(const std::string& path);
std::string lower_ext(const std::string& path);
// `path` relative to the folder `base` (both may be relative to the working directory).
std::string relative_to(const std::string& path, const std::string& base);
// The executable `name` in the folder of the running program (/proc/self/exe), or "" when there
// is none (or it may not be run).
std::string program_beside_self(const std::string& name);

}  // namespace aniso
