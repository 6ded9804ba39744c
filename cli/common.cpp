#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "cli/command.h"
#include "core/error.h"
#include "io/files/files.h"
#include "io/formats/capture.h"
#include "io/images/image_io.h"
#include "render/preview/preview.h"

namespace aniso::cli {

namespace {
std::string g_command_line;
std::vector<std::string> g_command_words;
}  // namespace

const std::string& command_line() { return g_command_line; }
const std::vector<std::string>& command_words() { return g_command_words; }

std::string shareable_command_line(const std::string& out_dir) {
  namespace fs = std::filesystem;
  auto relative = [&](const std::string& w) {
    std::error_code ec;
    if (w.empty() || w == "-" || (w[0] != '/' && !fs::exists(fs::symlink_status(w, ec)))) return w;
    return relative_to(w, out_dir);
  };
  std::string line = "aniso";
  for (size_t i = 1; i < g_command_words.size(); ++i) {
    std::string w = g_command_words[i];
    const size_t eq = w.rfind("--", 0) == 0 ? w.find('=') : std::string::npos;
    if (eq != std::string::npos)
      w = w.substr(0, eq + 1) + relative(w.substr(eq + 1));
    else if (i > 1 && !w.empty() && w[0] != '-')
      w = relative(w);
    line += " " + w;
  }
  return line;
}

void set_command_line(int argc, char** argv) {
  g_command_line.clear();
  g_command_words.assign(argv, argv + argc);
  for (int i = 0; i < argc; ++i) g_command_line += (i ? " " : "") + std::string(argv[i]);
}

void run_beside(const std::string& name, const std::string& missing) {
  const std::string path = program_beside_self(name);
  if (path.empty()) throw Error(missing);
  std::vector<std::string> words = command_words();
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  std::fflush(nullptr);
  ::execv(path.c_str(), argv.data());
  throw Error("cannot start " + path + ": " + std::strerror(errno));
}

void parse_size(const std::string& s, int* w, int* h, const char* opt) {
  long a = 0, b = 0;
  char x = 0, extra = 0;
  if (std::sscanf(s.c_str(), "%ld%c%ld%c", &a, &x, &b, &extra) == 3 && (x == 'x' || x == 'X')) {
  } else if (std::sscanf(s.c_str(), "%ld%c", &a, &extra) == 1) {
    b = a;
  } else {
    throw Error(std::string(opt) + ": expected WxH or N, got '" + s + "'");
  }
  constexpr long kMaxSide = 16384;  // keeps W * H * channels well inside memory and int
  if (a < 1 || b < 1 || a > kMaxSide || b > kMaxSide)
    throw Error(std::string(opt) + ": each side must be in [1, " + std::to_string(kMaxSide) +
                "], got '" + s + "'");
  *w = static_cast<int>(a);
  *h = static_cast<int>(b);
}

void add_exr_compression(CLI::App* sub, std::string* value, const std::string& what) {
  sub->add_option("--exr-compression", *value,
                  "EXR compression of " + what +
                      ": none (fastest), zip (zlib level 1: about half the size of smooth "
                      "images, 0.8 of noisy maps; ~40 MB/s a core) or piz")
      ->capture_default_str()
      ->check(CLI::IsMember({"zip", "piz", "none"}));
}

Vec3 parse_vec(const std::string& s, const std::string& opt) {
  Vec3 v;
  char extra;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf%c", &v.x, &v.y, &v.z, &extra) != 3 || !finite(v) ||
      length(v) == 0)
    throw Error(opt + ": expected a non-zero direction x,y,z, got '" + s + "'");
  return v;
}

void note_material_maps(const Material& m, const char* what) {
  if (!m.maps.any()) return;
  std::fprintf(stderr,
               "%s: NOTE: the material has maps (k_d, k_s, n, the fiber direction or the topology "
               "amplitude over uv); %s "
               "uses its scalar (mean) values: per-texel maps are not carried here yet\n",
               what, what);
}

std::string default_shape(const std::string& given, const Material& m, const char* command) {
  if (!given.empty()) return given;
  if (!m.maps.any()) return "sphere";
  std::fprintf(stderr,
               "%s: the material has maps: drawn on the flat sample, its uv over [0, 1]^2 as the "
               "sample lies (--shape sphere wraps them round a sphere, with a seam)\n",
               command);
  return "flat";
}

void add_force_flag(CLI::App* sub, bool* force, const char* help) {
  sub->add_flag(
      "--force", *force,
      help ? help
           : "where an output would be refused (a folder or file aniso did not write, one of "
             "another kind, or one changed since), move what is there aside to NAME.aniso-old-N "
             "and write the output: nothing is deleted, and an input is never replaced");
}

void load_material_maps(const Material& m, const std::string& map_override, PreviewOptions* p) {
  if (const auto* t = m.fiber() ? m.topology_as<TopologyMapRef>() : nullptr)
    // The map named by the material (relative to the material file), unless given.
    p->topology_map =
        load_topology_map(map_override.empty() ? join_path(m.base_dir, t->file) : map_override).h;
  if (const auto* t = m.fiber() ? m.topology_as<SMapRef>() : nullptr)
    p->s_map = read_image(join_path(m.base_dir, t->file)).image;
}

}  // namespace aniso::cli
