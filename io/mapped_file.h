// A file's bytes mapped read-only, for readers that take only some of them (an uncompressed
// EXR's rows): no copy through a buffer. A file that another program shortens while it is
// mapped would stop the process with SIGBUS ("Bus error") on reading past its new end: the
// first mapping installs a handler that, on the thread reading a mapping, prints an error naming
// the file instead and exits with status 1 (any other SIGBUS goes where it went before).
#pragma once
#include <cstddef>
#include <string>
#include <string_view>

namespace aniso {

class MappedFile {
 public:
  // Empty where the file cannot be mapped or its size is not `size` (the caller's, from when it
  // looked at the file): read it another way.
  MappedFile(const std::string& path, size_t size);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  std::string_view bytes() const { return bytes_; }
  bool empty() const { return bytes_.empty(); }

 private:
  std::string path_;
  std::string_view bytes_;
  const char* outer_ = nullptr;  // the mapping this thread read before this one, if any
};

}  // namespace aniso
