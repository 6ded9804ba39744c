// How a float EXR is compressed when written (io/images/image_io.h write_exr): an option each
// writer is handed, never a process-wide setting.
#pragma once
#include <string>

namespace aniso {

enum class ExrCompression {
  kZip,   // zlib level 1 (the default: within a few % of the default level's size, several times
          // faster)
  kPiz,   // OpenEXR's wavelet coder
  kNone,  // written at memory speed, by hand
};

// "zip", "piz" or "none"; throws naming the value otherwise.
ExrCompression exr_compression_named(const std::string& name);

}  // namespace aniso
