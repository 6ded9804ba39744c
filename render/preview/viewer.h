// `aniso view`: an interactive window (GLFW + Dear ImGui) around the preview. Drag to orbit the
// object, right-drag (or the sliders) to move the light; switch shape and fiber field, the
// model's terms, table lookups against the exact model, and an error heat-map. Each change
// re-renders through render_preview in the window's own OpenGL context, so what the window shows
// is exactly what `aniso preview` writes for the same settings.
#pragma once
#include <string>

#include "models/material.h"
#include "render/bake/bake.h"
#include "render/preview/preview.h"

namespace aniso {

struct ViewerOptions {
  PreviewOptions preview;     // the starting settings (size = the window's)
  std::string screenshot;     // non-empty: render, save the window as this PNG, and exit
  int screenshot_frames = 3;  // frames drawn before the screenshot
  std::string title = "aniso view";
  int show = 0;  // 0: the tables (as an engine draws them), 1: the exact model, 2: error x10
};

// Runs until the window closes (or, with a screenshot, after it is written). Throws when no
// window can be opened (no display: run under xvfb-run).
void run_viewer(const Material& m, const ViewerOptions& opt);

}  // namespace aniso
