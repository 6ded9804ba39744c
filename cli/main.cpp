// aniso: the command-line front end. main() only dispatches: each subcommand lives in its own
// cli/cmd_*.cpp. Library errors (aniso::Error) are printed with their file/key and exit 1; a
// mistyped subcommand or option gets a "did you mean" and exit 2.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "aniso_version.h"  // generated: ANISO_VERSION, ANISO_COMMIT
#include "cli/command.h"
#include "core/error.h"
#include "core/text.h"
#include "io/images/image_io.h"

using namespace aniso;

namespace {

std::vector<std::string> option_names(const CLI::App* app) {
  std::vector<std::string> names;
  for (const CLI::Option* o : app->get_options()) {
    for (const auto& l : o->get_lnames()) names.push_back("--" + l);
    for (const auto& s : o->get_snames()) names.push_back("-" + s);
  }
  return names;
}

// An option the chosen subcommand does not know, with the closest one it does.
bool explain_unknown_option(const CLI::App* sub, int argc, char** argv) {
  const std::vector<std::string> known = option_names(sub);
  for (int i = 2; i < argc; ++i) {
    std::string a = argv[i];
    if (a.size() < 2 || a[0] != '-' || a == "-") continue;
    if (a.rfind("--", 0) == 0 && a.find('=') != std::string::npos) a = a.substr(0, a.find('='));
    bool ok = false;
    for (const auto& k : known) ok = ok || k == a;
    if (ok) continue;
    const std::string best = closest(a, known);
    std::fprintf(stderr, "aniso %s: unknown option '%s'%s (aniso %s --help lists them)\n",
                 sub->get_name().c_str(), a.c_str(),
                 best.empty() ? "" : (" (did you mean '" + best + "'?)").c_str(),
                 sub->get_name().c_str());
    return true;
  }
  return false;
}

// A value outside an option's set (CLI11's "--model: Check fibre value in {auto->2,...} FAILED" or
// "--loss: fibre not in {huber,...}"), said plainly with the closest allowed value.
bool explain_bad_value(const CLI::App* sub, const std::string& what) {
  const size_t colon = what.find(": "), open = what.find('{'), close = what.rfind('}');
  if (colon == std::string::npos || open == std::string::npos || close == std::string::npos ||
      close < open)
    return false;
  const std::string option = what.substr(0, colon);
  std::string value;
  if (const size_t c = what.find("Check ", colon); c != std::string::npos) {
    const size_t e = what.find(" value in ", c);
    if (e == std::string::npos) return false;
    value = what.substr(c + 6, e - c - 6);
  } else if (const size_t n = what.find(" not in ", colon); n != std::string::npos) {
    value = what.substr(colon + 2, n - colon - 2);
  } else {
    return false;
  }
  std::vector<std::string> allowed;
  std::string item;
  for (size_t i = open + 1; i <= close; ++i) {
    const char c = what[i];
    if (c == ',' || c == '}') {
      if (const size_t arrow = item.find("->"); arrow != std::string::npos) item.resize(arrow);
      if (!item.empty()) allowed.push_back(item);
      item.clear();
    } else if (c != ' ') {
      item += c;
    }
  }
  if (allowed.empty()) return false;
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  const std::string best = closest(value, allowed);
  std::fprintf(stderr, "aniso %s: %s: '%s' is not one of %s%s\n", sub->get_name().c_str(),
               option.c_str(), value.c_str(), list.c_str(),
               best.empty() ? "" : (" (did you mean '" + best + "'?)").c_str());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
#ifdef __GLIBC__
  // Large buffers (a decoded view: 0.25-1 MB) in mappings of their own, given back when freed.
  // glibc raises this threshold to the size of the first such buffer freed, and the next views'
  // buffers then come from the heap, which keeps their pages: 0.8 MB (a tenth) of bm16's peak.
  mallopt(M_MMAP_THRESHOLD, 128 * 1024);
#endif
  cli::set_command_line(argc, argv);
  if (!cli::runs_here(argc, argv)) try {
      cli::run_beside("aniso-full",
                      "aniso: this command needs aniso-full beside this aniso (scripts/build.sh "
                      "builds both)");
    } catch (const Error& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
  CLI::App app{
      "aniso: measure and fit anisotropic materials (line-lighting model of Banks / Heidrich & "
      "Seidel; fiber model of Poulin & Fournier with Hast's topology).\n"
      "Pipeline: synth (simulated gonioreflectometer on Embree) -> fit (Ceres) -> bake (lookup "
      "tables) -> preview (OpenGL, headless).",
      "aniso"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "aniso " ANISO_VERSION " (commit " ANISO_COMMIT ")");
  const std::vector<cli::Command> commands = cli::register_commands(app);

  if (argc > 1 && argv[1][0] != '-') {
    std::vector<std::string> names;
    bool known = false;
    for (const auto& c : commands) {
      names.push_back(c.sub->get_name());
      known = known || names.back() == argv[1];
    }
    if (!known) {
      const std::string best = closest(argv[1], names);
      std::fprintf(stderr, "aniso: unknown subcommand '%s'%s (aniso --help lists them)\n", argv[1],
                   best.empty() ? "" : (" (did you mean '" + best + "'?)").c_str());
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    for (const auto& c : commands)
      if (c.sub->parsed() && explain_unknown_option(c.sub, argc, argv)) return 2;
    if (dynamic_cast<const CLI::ValidationError*>(&e) ||
        dynamic_cast<const CLI::ConversionError*>(&e))
      for (const auto& c : commands)
        if (c.sub->parsed() && explain_bad_value(c.sub, e.what())) return 2;
    return app.exit(e);
  }

  try {
    for (const auto& c : commands)
      if (c.sub->parsed()) return c.run();
  } catch (const Error& e) {
    std::fprintf(stderr, "aniso: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "aniso: internal error: %s\n", e.what());
    return 2;
  }
  return 0;
}
