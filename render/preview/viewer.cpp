#include "render/preview/viewer.h"

#include <epoxy/gl.h>
// GLFW after epoxy (epoxy provides the GL declarations).
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/angles.h"
#include "core/color.h"
#include "core/error.h"
#include "io/images/image_io.h"

namespace aniso {

namespace {

const char* kShapes[] = {"sphere", "disc", "cylinder", "torus", "flat"};
const char* kFields[] = {"(tangent)", "radial", "circular", "meridian"};
const char* kModes[] = {"tables (the engine's view)", "exact model (CPU)", "error heat-map x10"};

// What the panel changes; anything else stays as the options gave it.
struct ViewState {
  int shape = 0, field = 0, mode = 0;
  bool diffuse = true, specular = true, isotropic = true, second = true;
  float view_az = -90, view_el = 37, light_az = -16, light_el = 44;
  float exposure = 1, fill = 0.15f;
  bool perspective = false;
  bool environment = false;  // light from the environment instead of the light (where given)
};

Vec3 from_angles(float az_deg, float el_deg) {
  const double a = deg_to_rad(az_deg), e = deg_to_rad(el_deg);
  return Vec3(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
}
void to_angles(const Vec3& v_in, float* az, float* el) {
  const Vec3 v = normalize(v_in);
  *az = float(rad_to_deg(std::atan2(v.y, v.x)));
  *el = float(rad_to_deg(std::asin(std::clamp(v.z, -1.0, 1.0))));
}

// The material with the terms switched off that the panel says.
Material with_terms(const Material& m, const ViewState& s) {
  Material out = m;
  if (!s.diffuse) out.kd = {0, 0, 0};
  if (!s.specular) out.ks = {0, 0, 0};
  if (!s.isotropic) out.has_isotropic = false;
  if (!s.second) out.has_second_fiber = false;
  return out;
}

// The image the window shows, 8-bit sRGB RGBA: the render, the exact model, or |difference|.
std::vector<uint8_t> display_pixels(const PreviewResult& r, const ViewState& s,
                                    const PreviewOptions& p) {
  const int w = r.rgb.width, h = r.rgb.height;
  std::vector<uint8_t> px(static_cast<size_t>(w) * h * 4, 255);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      for (int c = 0; c < 3; ++c) {
        double v = r.rgb.at(x, y, c);
        if (s.mode >= 1 && r.covered[i] && !r.reference.empty()) {
          const double ref = r.reference.at(x, y, c);
          v = s.mode == 1 ? ref : 10.0 * std::abs(v - ref);
        } else if (s.mode == 2) {
          v = r.covered[i] ? 0.0 : p.background[c];
        }
        px[4 * i + c] = static_cast<uint8_t>(std::lround(255.0 * srgb_encode(v * s.exposure)));
      }
    }
  return px;
}

class Window {
 public:
  Window(int w, int h, const std::string& title) {
    glfwSetErrorCallback([](int code, const char* what) {
      std::fprintf(stderr, "view: GLFW error %d: %s\n", code, what);
    });
    if (!glfwInit())
      throw Error(
          "view: cannot open a window (no display? run it as `xvfb-run -a aniso view ...`)");
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
    win_ = glfwCreateWindow(w, h, title.c_str(), nullptr, nullptr);
    if (!win_) {
      glfwTerminate();
      throw Error("view: cannot create an OpenGL 3.3 window");
    }
    glfwMakeContextCurrent(win_);
    glfwSwapInterval(1);
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // nothing written beside the user's files
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForOpenGL(win_, true);
    ImGui_ImplOpenGL3_Init("#version 330 core");
  }
  ~Window() {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(win_);
    glfwTerminate();
  }
  GLFWwindow* get() const { return win_; }

 private:
  GLFWwindow* win_ = nullptr;
};

// The control panel; returns whether anything changed.
bool panel(const Material& m, ViewState* s, const PreviewResult& r, double ms,
           const Environment* env) {
  bool changed = false;
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_Once);
  ImGui::SetNextWindowBgAlpha(0.8f);
  ImGui::Begin("aniso", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  changed |= ImGui::Combo("shape", &s->shape, kShapes, 5);
  changed |= ImGui::Combo("fiber field", &s->field, kFields, 4);
  changed |= ImGui::Combo("show", &s->mode, kModes, 3);
  changed |= ImGui::Checkbox("diffuse", &s->diffuse);
  ImGui::SameLine();
  changed |= ImGui::Checkbox("specular", &s->specular);
  if (m.has_isotropic) changed |= ImGui::Checkbox("isotropic", &s->isotropic);
  if (m.has_second_fiber) changed |= ImGui::Checkbox("second fiber", &s->second);
  if (env) {
    const std::string label = "environment (" + env->name + ")";
    changed |= ImGui::Checkbox(label.c_str(), &s->environment);
  }
  if (!s->environment) {
    changed |= ImGui::SliderFloat("light azimuth", &s->light_az, -180, 180);
    changed |= ImGui::SliderFloat("light elevation", &s->light_el, -89, 89);
    changed |= ImGui::SliderFloat("fill", &s->fill, 0, 1);
  } else if (s->mode > 0) {
    s->mode = 0, changed = true;  // brute force under an environment takes seconds a frame
  }
  changed |=
      ImGui::SliderFloat("exposure", &s->exposure, 0.05f, 20, "%.2f", ImGuiSliderFlags_Logarithmic);
  changed |= ImGui::Checkbox("perspective", &s->perspective);
  ImGui::Text("%s model, %d pass%s, %.1f ms per render", model_name(m.model), r.passes,
              r.passes == 1 ? "" : "es", ms);
  if (!r.reference.empty())
    ImGui::Text("tables vs exact: max abs %.3g (bound %.3g)", r.max_abs_diff, r.error_bound);
  ImGui::TextUnformatted(s->environment ? "drag: orbit   (the exact and error views: light only)"
                                        : "drag: orbit   right-drag: light");
  ImGui::End();
  return changed;
}

// Mouse drags outside the panel turn the view (left) or the light (right).
bool drag(ViewState* s) {
  const ImGuiIO& io = ImGui::GetIO();
  if (io.WantCaptureMouse) return false;
  const float dx = io.MouseDelta.x * 0.4f, dy = io.MouseDelta.y * 0.4f;
  if (dx == 0 && dy == 0) return false;
  if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
    s->view_az -= dx;
    s->view_el = std::clamp(s->view_el + dy, -89.f, 89.f);
    return true;
  }
  if (ImGui::IsMouseDown(ImGuiMouseButton_Right) && !s->environment) {
    s->light_az -= dx;
    s->light_el = std::clamp(s->light_el + dy, -89.f, 89.f);
    return true;
  }
  return false;
}

void save_screenshot(const std::string& path, int w, int h) {
  std::vector<uint8_t> buf(static_cast<size_t>(w) * h * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, buf.data());
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.at(x, y, c) = buf[(static_cast<size_t>(h - 1 - y) * w + x) * 3 + c] / 255.f;
  write_png(path, img, 8);
}

}  // namespace

void run_viewer(const Material& m, const ViewerOptions& opt) {
  PreviewOptions p = opt.preview;
  p.use_current_context = true;
  ViewState s;
  for (int i = 0; i < 5; ++i)
    if (p.shape == kShapes[i]) s.shape = i;
  for (int i = 1; i < 4; ++i)
    if (p.fiber_field == kFields[i]) s.field = i;
  to_angles(p.view_dir, &s.view_az, &s.view_el);
  if (!p.light_dirs.empty()) to_angles(p.light_dirs[0], &s.light_az, &s.light_el);
  s.fill = float(p.fill);
  s.perspective = p.perspective;
  s.mode = std::clamp(opt.show, 0, 2);
  const Window window(p.width, p.height, opt.title);
  // The tables depend on n only (colours are uniforms): baked once for every later render.
  PreviewBakes bakes;
  bake_for_frames(m, &p, &bakes);
  // An environment: prefiltered for the terms shown (again when they change), its light not moved
  // by the drag; the panel switches between it and the light.
  const Environment* env = p.environment;
  s.environment = env != nullptr;
  EnvironmentTables prefiltered;
  std::pair<bool, bool> prefiltered_for{false, false};  // (diffuse, specular) shown
  // A material with maps: D and S apart, once (the terms shown are its k_d or k_s at 0).
  EnvironmentParts parts;
  // The fiber model: D and S apart as well, once.
  FiberEnvironmentTables fiber_prefiltered;
  // The isotropic term's tables depend on its n alone: once.
  IsotropicEnvironment iso_prefiltered;
  if (env && m.isotropic_active()) iso_prefiltered = prefilter_isotropic_environment(*env, m.iso_n);
  auto refilter = [&](const Material& shown) {
    if (m.fiber()) {
      if (fiber_prefiltered.w == 0)
        fiber_prefiltered = prefilter_fiber_environment(*env, m, *p.baked, *p.baked_fiber);
      return;
    }
    if (m.maps.any()) {
      if (parts.diffuse.w == 0) parts = prefilter_environment_parts(*env, *p.baked, &m);
      return;
    }
    if (prefiltered.w > 0 && prefiltered_for == std::pair{s.diffuse, s.specular}) return;
    prefiltered = prefilter_environment(*env, bake_line(shown, p.baked->size, p.baked->index));
    prefiltered_for = {s.diffuse, s.specular};
  };
  GLuint tex = 0;
  glGenTextures(1, &tex);
  PreviewResult r;
  bool dirty = true;
  double ms = 0;
  for (int frame = 0; !glfwWindowShouldClose(window.get()); ++frame) {
    glfwPollEvents();
    if (dirty) {
      p.shape = kShapes[s.shape];
      p.fiber_field = s.field ? kFields[s.field] : "";
      p.view_dir = from_angles(s.view_az, s.view_el);
      p.light_dirs = {from_angles(s.light_az, s.light_el)};
      p.fill = s.fill;
      p.perspective = s.perspective;
      p.reference = s.mode > 0;
      const Material shown = with_terms(m, s);
      p.environment = s.environment ? env : nullptr;
      p.prefiltered = nullptr;
      p.prefiltered_parts = nullptr;
      p.prefiltered_fiber = nullptr;
      p.prefiltered_isotropic = iso_prefiltered.w > 0 ? &iso_prefiltered : nullptr;
      if (p.environment) {
        refilter(shown);
        if (m.fiber())
          p.prefiltered_fiber = &fiber_prefiltered;
        else if (m.maps.any())
          p.prefiltered_parts = &parts;
        else
          p.prefiltered = &prefiltered;
      }
      const auto t0 = std::chrono::steady_clock::now();
      r = render_preview(shown, p);
      ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const std::vector<uint8_t> px = display_pixels(r, s, p);
      glBindTexture(GL_TEXTURE_2D, tex);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
      glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, p.width, p.height, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                   px.data());
      dirty = false;
    }
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    // The render fills the window at one texel per pixel (row 0 of the image at the top).
    ImGui::GetBackgroundDrawList()->AddImage(
        reinterpret_cast<ImTextureID>(static_cast<intptr_t>(tex)), ImVec2(0, 0),
        ImVec2(float(p.width), float(p.height)));
    dirty |= panel(m, &s, r, ms, env);
    dirty |= drag(&s);
    ImGui::Render();
    int fw, fh;
    glfwGetFramebufferSize(window.get(), &fw, &fh);
    glViewport(0, 0, fw, fh);
    glClearColor(0, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (!opt.screenshot.empty() && frame + 1 >= opt.screenshot_frames) {
      save_screenshot(opt.screenshot, fw, fh);
      break;
    }
    glfwSwapBuffers(window.get());
  }
  glDeleteTextures(1, &tex);
}

}  // namespace aniso
