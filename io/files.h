// File helpers: atomic writes (temporary name, then rename) so no output is ever half-written.
#pragma once
#include <functional>
#include <string>

namespace aniso {

// A temporary sibling of `path` that keeps its extension (OpenCV picks the codec by extension).
std::string temp_sibling(const std::string& path);

// Calls write(tmp) and renames tmp to path; removes tmp and rethrows if write throws.
void write_atomically(const std::string& path,
                      const std::function<void(const std::string&)>& write);

void write_text_file(const std::string& path, const std::string& text);
std::string read_text_file(const std::string& path);

// Writes a whole folder atomically: fill(tmp_dir) then rename tmp_dir to dir (replacing dir).
void write_folder_atomically(const std::string& dir,
                             const std::function<void(const std::string&)>& fill);

std::string join_path(const std::string& dir, const std::string& rel);
std::string parent_dir(const std::string& path);
std::string lower_ext(const std::string& path);

}  // namespace aniso
