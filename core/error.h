// The one exception type the library throws. Its message names the file, key or value at fault;
// the CLI catches it, prints it, and exits non-zero. Library code never calls exit().
#pragma once
#include <stdexcept>
#include <string>

namespace aniso {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace aniso
