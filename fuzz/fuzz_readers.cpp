// libFuzzer target: every file reader on arbitrary bytes. The first byte picks the reader
// (capture.json, material, sample table, image, OBJ, photo shoot, RGL .bsdf); the rest is the
// file. A reader
// may reject the file with aniso::Error; anything else (a crash, another exception, a sanitizer
// report) is a bug. Build and run: scripts/fuzz.sh. With ANISO_FUZZ_SET naming a real capture
// folder, its files are copied beside the fuzzed capture.json first, so a mutated capture.json that
// still names them reaches image decoding and the per-pixel checks (the corpus holds that set's
// capture.json, and real PNG and EXR files).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/error.h"
#include "geometry/mesh.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "io/formats/rgl_bsdf.h"
#include "io/formats/table.h"
#include "io/images/image_io.h"
#include "photo/shoot/shoot.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* kExt[] = {".json", ".json", ".csv", ".png", ".exr", ".obj", ".json", ".bsdf"};
  const int which = data[0] % 8;
  const std::string dir = "/tmp/aniso_fuzz_" + std::to_string(::getpid());
  static bool seeded = false;
  if (!seeded) {
    seeded = true;
    std::string cmd = "mkdir -p " + dir;
    if (const char* set = std::getenv("ANISO_FUZZ_SET"))
      cmd += " && cp -r " + std::string(set) + "/. " + dir + "/";
    if (std::system(cmd.c_str()) != 0) return 0;
  }
  const std::string path = dir + (which == 0 ? "/capture" : "/input") + kExt[which];
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
  }
  try {
    switch (which) {
      case 0: {
        const aniso::CaptureSet s = aniso::read_capture(path);
        for (size_t i = 0; i < s.views.size() && i < 2; ++i) aniso::load_view(s, i);
        break;
      }
      case 1:
        aniso::read_material(path);
        break;
      case 2:
        aniso::read_table(path);
        break;
      case 3:
      case 4:
        aniso::read_image(path);
        break;
      case 5:
        aniso::load_obj(path);
        break;
      case 6:
        aniso::read_shoot(path);
        break;
      case 7: {  // a file that reads is evaluated too
        const aniso::RglBsdf b = aniso::RglBsdf::read(path);
        b.eval({0.3, 0.2, 0.93}, {-0.5, 0.1, 0.86});
        break;
      }
    }
  } catch (const aniso::Error&) {
    // A clear rejection is the expected outcome for most inputs.
  }
  return 0;
}
