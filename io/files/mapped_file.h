// A file's bytes mapped read-only, for readers that take only some of them (an uncompressed
// EXR's rows): no copy through a buffer. A file that another program shortens while it is
// mapped would stop the process with SIGBUS ("Bus error") on reading past its new end: the
// first mapping installs a handler that, for a fault inside a mapping the faulting thread holds,
// prints an error naming the file instead and exits with status 1 (any other SIGBUS goes where it
// went before).
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
  const std::string& path() const { return path_; }
  // Whether `address` is one of the mapped bytes.
  bool holds(const void* address) const {
    const char* a = static_cast<const char*>(address);
    return !bytes_.empty() && a >= bytes_.data() && a < bytes_.data() + bytes_.size();
  }
  // The mapping this thread held when this one was made, if any.
  const MappedFile* outer() const { return outer_; }

 private:
  std::string path_;
  std::string_view bytes_;
  const MappedFile* outer_ = nullptr;
};

}  // namespace aniso
