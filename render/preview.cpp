#include "render/preview.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <chrono>
#include <cmath>

#include "core/angles.h"
#include "core/error.h"
#include "core/frame.h"
#include "core/texture.h"
#include "geometry/topology.h"
#include "io/capture.h"
#include "io/files.h"
#include "models/evaluate.h"
#include "models/topology.h"
#include "render/bake.h"

namespace aniso {

namespace {

// A headless OpenGL 3.3 core context on EGL's surfaceless platform (Mesa llvmpipe or a GPU).
class GlContext {
 public:
  GlContext() {
    if (!epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless"))
      fail("EGL_MESA_platform_surfaceless is not available");
    dpy_ = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (dpy_ == EGL_NO_DISPLAY) fail("no surfaceless EGL display");
    EGLint major = 0, minor = 0;
    if (!eglInitialize(dpy_, &major, &minor)) fail("eglInitialize failed");
    if (!eglBindAPI(EGL_OPENGL_API)) fail("eglBindAPI(OpenGL) failed");
    const EGLint cfg_attr[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig cfg;
    EGLint n = 0;
    if (!eglChooseConfig(dpy_, cfg_attr, &cfg, 1, &n) || n < 1) fail("no EGL config with OpenGL");
    const EGLint ctx_attr[] = {EGL_CONTEXT_MAJOR_VERSION,
                               3,
                               EGL_CONTEXT_MINOR_VERSION,
                               3,
                               EGL_CONTEXT_OPENGL_PROFILE_MASK,
                               EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                               EGL_NONE};
    ctx_ = eglCreateContext(dpy_, cfg, EGL_NO_CONTEXT, ctx_attr);
    if (ctx_ == EGL_NO_CONTEXT) fail("cannot create an OpenGL 3.3 core context");
    if (!eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx_)) fail("eglMakeCurrent failed");
  }
  ~GlContext() {
    if (dpy_ != EGL_NO_DISPLAY) {
      eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (ctx_ != EGL_NO_CONTEXT) eglDestroyContext(dpy_, ctx_);
      eglTerminate(dpy_);
    }
  }
  [[noreturn]] void fail(const std::string& what) {
    throw Error("preview: cannot create a headless OpenGL context (EGL surfaceless, Mesa): " +
                what + " (EGL error 0x" + hex(eglGetError()) + ")");
  }
  static std::string hex(EGLint v) {
    char b[16];
    std::snprintf(b, sizeof b, "%x", v);
    return b;
  }

 private:
  EGLDisplay dpy_ = EGL_NO_DISPLAY;
  EGLContext ctx_ = EGL_NO_CONTEXT;
};

GLuint compile(GLenum type, const char* src) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    throw Error(std::string("preview: shader compile error: ") + log);
  }
  return s;
}

GLuint program(const char* vs, const char* fs) {
  GLuint p = glCreateProgram();
  GLuint a = compile(GL_VERTEX_SHADER, vs), b = compile(GL_FRAGMENT_SHADER, fs);
  glAttachShader(p, a);
  glAttachShader(p, b);
  glLinkProgram(p);
  glDeleteShader(a);
  glDeleteShader(b);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    throw Error(std::string("preview: shader link error: ") + log);
  }
  return p;
}

const char* kVertex = R"(#version 330 core
layout(location = 0) in vec3 aP;
layout(location = 1) in vec3 aN;
layout(location = 2) in vec3 aT;
layout(location = 3) in vec3 aT2;
layout(location = 4) in vec2 aUV;
layout(location = 5) in float aSmath;
uniform mat4 uViewProj;
out vec3 vN; out vec3 vT; out vec3 vT2; out vec2 vUV; out float vSmath;
invariant gl_Position;
void main() {
  vN = aN; vT = aT; vT2 = aT2; vUV = aUV; vSmath = aSmath;
  gl_Position = uViewProj * vec4(aP, 1.0);
}
)";

// The anisotropic pass: the paper's texture matrix applied to (T, 1), two lookups (D, S) so the
// colours stay uniforms, and Banks' self-shadowing <N,L>^+ per fragment.
const char* kAniso = R"(#version 330 core
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform mat4 uTexMat;
uniform sampler2D uD;
uniform sampler2D uS;
uniform vec3 uL; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs;
uniform float uWeight; uniform int uUseT2;
uniform int uAngleIndex; uniform float uTexels;
out vec4 frag;
const float PI = 3.14159265358979;
void main() {
  vec3 N = normalize(vN);
  vec3 T = uUseT2 == 1 ? vT2 : vT;
  T = normalize(T - N * dot(N, T));
  vec2 st = (uTexMat * vec4(T, 1.0)).xy;
  if (uAngleIndex == 1)  // s = (a + 1) / 2 -> texel centre of acos(-a) (render/bake.h)
    st = (acos(clamp(1.0 - 2.0 * st, -1.0, 1.0)) / PI * (uTexels - 1.0) + 0.5) / uTexels;
  float D = texture(uD, st).r;
  float S = texture(uS, st).r;
  frag = vec4(uE * uWeight * (uKd * D + uKs * S) * max(dot(N, uL), 0.0), 1.0);
}
)";

// The paper's construction to the letter: the texture matrix applied per vertex to (T, 1), the
// coordinates interpolated, one lookup per table, <N,L>^+ per fragment.
const char* kVertexPaper = R"(#version 330 core
layout(location = 0) in vec3 aP;
layout(location = 1) in vec3 aN;
layout(location = 2) in vec3 aT;
uniform mat4 uViewProj;
uniform mat4 uTexMat;
out vec3 vN; out vec2 vST;
invariant gl_Position;
void main() { vN = aN; vST = (uTexMat * vec4(aT, 1.0)).xy; gl_Position = uViewProj * vec4(aP, 1.0); }
)";
const char* kAnisoPaper = R"(#version 330 core
in vec3 vN; in vec2 vST;
uniform sampler2D uD; uniform sampler2D uS;
uniform vec3 uL; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs; uniform float uWeight;
out vec4 frag;
void main() {
  frag = vec4(uE * uWeight * (uKd * texture(uD, vST).r + uKs * texture(uS, vST).r) * max(dot(normalize(vN), uL), 0.0), 1.0);
}
)";

// Isotropic component (seed 000 §4): Lambert + Blinn-Phong, one pass per light.
const char* kIso = R"(#version 330 core
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform vec3 uL; uniform vec3 uV; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs; uniform float uN;
out vec4 frag;
void main() {
  vec3 N = normalize(vN);
  float nl = dot(N, uL);
  if (nl <= 0.0) { frag = vec4(0.0, 0.0, 0.0, 1.0); return; }
  vec3 H = normalize(uL + uV);
  float nh = max(dot(N, H), 0.0);
  frag = vec4(uE * (uKd * nl + uKs * (nh > 0.0 ? exp(uN * log(nh)) : 0.0)), 1.0);
}
)";

// A plain textured-and-lit pass (ordinary uv texture times Lambert), for timing comparisons.
const char* kPlain = R"(#version 330 core
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform sampler2D uD;
uniform vec3 uL; uniform vec3 uE; uniform vec3 uKd;
out vec4 frag;
void main() {
  vec3 N = normalize(vN);
  float tex = texture(uD, vT.xy * 0.5 + 0.5).r;
  frag = vec4(uE * uKd * tex * max(dot(N, uL), 0.0), 1.0);
}
)";

// Geometry pass for the reference: N, T, T2 (orthonormalised like the shading pass); for the
// fiber model the third target holds (u, v, s_math) instead of T2.
const char* kGBuffer = R"(#version 330 core
in vec3 vN; in vec3 vT; in vec3 vT2; in vec2 vUV; in float vSmath;
uniform int uFiber;
layout(location = 0) out vec4 oN;
layout(location = 1) out vec4 oT;
layout(location = 2) out vec4 oT2;
void main() {
  vec3 N = normalize(vN);
  oN = vec4(N, 1.0);
  oT = vec4(normalize(vT - N * dot(N, vT)), 1.0);
  oT2 = uFiber == 1 ? vec4(vUV, vSmath, 1.0) : vec4(normalize(vT2 - N * dot(N, vT2)), 1.0);
}
)";

// The fiber model from its baked form (render/bake.h): the line tables through the paper's
// texture matrix times the factor tables G(phi_l, phi_v, s) and F(phi_l, phi_v, s, k), with the
// topology s per fragment from the mathematical topology and the topology map (MODELS.md §4).
const char* kFiber = R"(#version 330 core
in vec3 vN; in vec3 vT; in vec3 vT2; in vec2 vUV; in float vSmath;
uniform mat4 uTexMat;
uniform sampler2D uD;
uniform sampler2D uS;
uniform sampler2DArray uG;
uniform sampler2DArray uF;
uniform sampler2D uMap;
uniform int uAngleIndex; uniform float uTexels;
uniform int uNphi; uniform int uNs; uniform int uNk;
uniform int uTopo;  // 0: uniform s, 1: s_math, 2: s_math + map, 3: a map of s itself
uniform float uS0; uniform float uAmp;
uniform vec3 uL; uniform vec3 uV; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs;
out vec4 frag;
const float PI = 3.14159265358979;
void main() {
  vec3 N = normalize(vN);
  vec3 T = normalize(vT - N * dot(N, vT));
  vec3 B = cross(N, T);
  float ln = dot(uL, N), vn = dot(uV, N);
  if (ln <= 0.0 || vn <= 0.0) { frag = vec4(0.0, 0.0, 0.0, 1.0); return; }
  vec2 st = (uTexMat * vec4(T, 1.0)).xy;
  if (uAngleIndex == 1) st = (acos(clamp(1.0 - 2.0 * st, -1.0, 1.0)) / PI * (uTexels - 1.0) + 0.5) / uTexels;
  float Dl = texture(uD, st).r, Sl = texture(uS, st).r;
  float a = dot(uL, T), b = dot(uV, T), lb = dot(uL, B), vb = dot(uV, B);
  float sL = length(vec2(lb, ln)), sV = length(vec2(vb, vn));
  float g0 = sL * sV - a * b;
  float kk = g0 > 0.0 ? 2.0 * sL * sV / (g0 + 2.0 * sL * sV) : 1.0;
  float s = uS0;
  if (uTopo >= 1) s = vSmath;
  if (uTopo == 3) s = texture(uMap, vUV).r;
  if (uTopo == 2) {
    float m = 2.0 * texture(uMap, vUV).r - 1.0;
    float H = clamp(2.0 * sin(PI / 3.0 * vSmath) + uAmp * m, 0.0, sqrt(3.0));
    s = asin(0.5 * H) / (PI / 3.0);
  }
  vec2 uvphi = ((vec2(atan(lb, ln), atan(vb, vn)) + 0.5 * PI) / PI * float(uNphi - 1) + 0.5) / float(uNphi);
  float fs = clamp(s, 0.0, 1.0) * float(uNs - 1);
  int is = min(int(fs), uNs - 2);
  float ws = fs - float(is);
  float fk = kk * float(uNk - 1);
  int ik = min(int(fk), uNk - 2);
  float wk = fk - float(ik);
  float G = mix(texture(uG, vec3(uvphi, float(is))).r, texture(uG, vec3(uvphi, float(is + 1))).r, ws);
  float F0 = mix(texture(uF, vec3(uvphi, float(is * uNk + ik))).r, texture(uF, vec3(uvphi, float(is * uNk + ik + 1))).r, wk);
  float F1 = mix(texture(uF, vec3(uvphi, float((is + 1) * uNk + ik))).r,
                 texture(uF, vec3(uvphi, float((is + 1) * uNk + ik + 1))).r, wk);
  float F = mix(F0, F1, ws);
  frag = vec4(uE * (uKd * Dl * G + uKs * Sl * F), 1.0);
}
)";

GLuint make_array_texture(const std::vector<float>& data, int w, int h, int layers) {
  GLuint tex;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_2D_ARRAY, tex);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_R32F, w, h, layers, 0, GL_RED, GL_FLOAT, data.data());
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return tex;
}

GLuint make_table_texture(const Image& t) {
  GLuint tex;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_2D, tex);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, t.width, t.height, 0, GL_RED, GL_FLOAT, t.px.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return tex;
}

void set3(GLuint p, const char* name, const Vec3& v) {
  glUniform3f(glGetUniformLocation(p, name), float(v.x), float(v.y), float(v.z));
}
void set3(GLuint p, const char* name, const RGB& v) {
  glUniform3f(glGetUniformLocation(p, name), float(v[0]), float(v[1]), float(v[2]));
}
void setm(GLuint p, const char* name, const float* m) {
  glUniformMatrix4fv(glGetUniformLocation(p, name), 1, GL_TRUE, m);
}

Image read_attachment(int attachment, int w, int h) {
  std::vector<float> buf(static_cast<size_t>(w) * h * 4);
  glReadBuffer(GL_COLOR_ATTACHMENT0 + attachment);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, buf.data());
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.at(x, y, c) = buf[(static_cast<size_t>(h - 1 - y) * w + x) * 4 + c];
  return img;
}

}  // namespace

PreviewResult render_preview(const Material& m, const PreviewOptions& opt) {
  if (opt.width < 1 || opt.height < 1 || opt.width > 8192 || opt.height > 8192)
    throw Error("preview: --size must be between 1x1 and 8192x8192");
  if (opt.light_dirs.empty()) throw Error("preview: at least one light is needed");
  const bool is_obj = lower_ext(opt.shape) == ".obj";
  TriMesh mesh = is_obj ? load_obj(opt.shape, opt.fiber_field.empty())
                        : make_shape(opt.shape, opt.shape_options);
  PreviewResult res;
  res.triangles = mesh.tri.size();

  // Per-vertex fiber directions T and T2 (MODELS.md §1), uv and the mathematical topology.
  const bool fiber = m.fiber() && !opt.plain;
  const auto* map_ref = m.topology_as<TopologyMapRef>();
  const auto* s_map_ref = m.topology_as<SMapRef>();
  if (fiber && s_map_ref && opt.s_map.empty())
    throw Error("preview: the material uses a map of s (" + s_map_ref->file +
                ") but none was loaded");
  if (fiber && map_ref && opt.topology_map.empty())
    throw Error("preview: the material uses a topology map (" + map_ref->file +
                ") but none was loaded");
  const double psi = deg_to_rad(m.fiber_angle_deg), psi2 = deg_to_rad(m.second_angle_deg);
  std::vector<float> vbuf;
  double radius = 0;
  for (size_t i = 0; i < mesh.P.size(); ++i) {
    const Vec3 N = normalize(mesh.N[i]);
    const Vec3 U =
        fiber_field_tangent(opt.fiber_field, mesh.P[i], N, mesh.U[i], mesh.center, mesh.axis);
    const Vec3 W = cross(N, U);
    const Vec3 T = U * std::cos(psi) + W * std::sin(psi),
               T2 = U * std::cos(psi2) + W * std::sin(psi2);
    for (const Vec3& v : {mesh.P[i], N, T, T2}) {
      vbuf.push_back(float(v.x));
      vbuf.push_back(float(v.y));
      vbuf.push_back(float(v.z));
    }
    vbuf.push_back(mesh.uv[i][0]);
    vbuf.push_back(mesh.uv[i][1]);
    vbuf.push_back(float(mathematical_topology_at(m.mathematical(), mesh.P[i], opt.shape_options)));
    radius = std::max(radius, length(mesh.P[i] - mesh.center));
  }

  GlContext gl;
  res.renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const int w = opt.width, h = opt.height;
  GLuint vao, vbo, ibo;
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glGenBuffers(1, &vbo);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glBufferData(GL_ARRAY_BUFFER, vbuf.size() * sizeof(float), vbuf.data(), GL_STATIC_DRAW);
  constexpr int kStride = 15 * sizeof(float);
  for (int a = 0; a < 6; ++a) {
    glEnableVertexAttribArray(a);
    const int size = a < 4 ? 3 : (a == 4 ? 2 : 1);
    const size_t offset = a < 4 ? a * 3 : (a == 4 ? 12 : 14);
    glVertexAttribPointer(a, size, GL_FLOAT, GL_FALSE, kStride,
                          reinterpret_cast<void*>(offset * sizeof(float)));
  }
  glGenBuffers(1, &ibo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, mesh.tri.size() * 3 * sizeof(uint32_t), mesh.tri.data(),
               GL_STATIC_DRAW);

  // Framebuffer: three float colour attachments (the reference pass uses all three) and depth.
  GLuint fbo, color[3], depth;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glGenTextures(3, color);
  for (int i = 0; i < 3; ++i) {
    glBindTexture(GL_TEXTURE_2D, color[i]);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, nullptr);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D, color[i], 0);
  }
  glGenRenderbuffers(1, &depth);
  glBindRenderbuffer(GL_RENDERBUFFER, depth);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error("preview: float framebuffer incomplete on " + res.renderer);
  glViewport(0, 0, w, h);

  // Orthographic camera looking along -view_dir (a distant viewer: V constant, as in the paper).
  const Vec3 V = normalize(opt.view_dir);
  Vec3 right = cross(Vec3(0, 0, 1), V);
  if (length(right) < 1e-6) right = Vec3(1, 0, 0);
  right = normalize(right);
  const Vec3 up = cross(V, right);
  const double aspect = double(w) / h, ext = 1.1 * radius;
  const Vec3 c = mesh.center;
  const float view_proj[16] = {float(right.x / (ext * aspect)),
                               float(right.y / (ext * aspect)),
                               float(right.z / (ext * aspect)),
                               float(-dot(right, c) / (ext * aspect)),
                               float(up.x / ext),
                               float(up.y / ext),
                               float(up.z / ext),
                               float(-dot(up, c) / ext),
                               float(-V.x / (2 * ext)),
                               float(-V.y / (2 * ext)),
                               float(-V.z / (2 * ext)),
                               float(dot(V, c) / (2 * ext)),
                               0,
                               0,
                               0,
                               1};

  const bool paper = opt.per_vertex && !opt.plain && !m.fiber();
  const BakeIndex index = opt.baked                        ? opt.baked->index
                          : opt.table_index == 1 && !paper ? BakeIndex::kAngle
                                                           : BakeIndex::kCosine;
  if (paper && index != BakeIndex::kCosine)
    throw Error("preview: --per-vertex (the paper's construction) needs a cosine-index bake");
  const BakeTables tables = opt.baked ? *opt.baked : bake_line(m, opt.table_size, index);
  GLuint texD = make_table_texture(tables.diffuse), texS = make_table_texture(tables.specular);
  const GLuint p_aniso = paper ? program(kVertexPaper, kAnisoPaper)
                               : program(kVertex, opt.plain ? kPlain : (fiber ? kFiber : kAniso));
  FiberBakeTables fb;
  GLuint texG = 0, texF = 0, texMap = 0;
  if (fiber) {
    if (opt.baked_fiber)
      fb = *opt.baked_fiber;
    else
      fb = bake_fiber(m, tables);
    texG = make_array_texture(fb.G, fb.nphi, fb.nphi, fb.ns);
    texF = make_array_texture(fb.F, fb.nphi, fb.nphi, fb.ns * fb.nk);
    if (map_ref || s_map_ref) {
      const Image& img = s_map_ref ? opt.s_map : opt.topology_map;
      std::vector<float> first(static_cast<size_t>(img.width) * img.height);
      for (size_t p = 0; p < first.size(); ++p) first[p] = img.px[p * img.channels];
      glGenTextures(1, &texMap);
      glBindTexture(GL_TEXTURE_2D, texMap);
      // Row 0 of the image is v = 0 (glTF: top), which is t = 0 here: the same convention.
      glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, img.width, img.height, 0, GL_RED, GL_FLOAT,
                   first.data());
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    }
  }
  const GLuint p_iso = program(kVertex, kIso);
  const GLsizei nidx = static_cast<GLsizei>(mesh.tri.size() * 3);
  // The paper's matrix; for the cosine index the texel-centre remap is folded into it.
  const bool angle = index == BakeIndex::kAngle;
  const double k = angle ? 1.0 : (tables.size - 1.0) / tables.size,
               o = angle ? 0.0 : 0.5 / tables.size;

  const GLenum one[] = {GL_COLOR_ATTACHMENT0};
  glDrawBuffers(1, one);
  glEnable(GL_DEPTH_TEST);
  const auto t0 = std::chrono::steady_clock::now();
  for (int frame = 0; frame < std::max(1, opt.repeat); ++frame) {
    res.passes = 0;
    glClearColor(0, 0, 0, 0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glDisable(GL_BLEND);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    auto begin_pass = [&]() {
      if (res.passes == 1) {  // every pass after the first adds onto the image
        glEnable(GL_BLEND);
        glBlendFunc(GL_ONE, GL_ONE);
        glDepthFunc(GL_LEQUAL);
        glDepthMask(GL_FALSE);
      }
      ++res.passes;
    };
    for (const Vec3& ld : opt.light_dirs) {
      const Vec3 L = normalize(ld);
      const float texmat[16] = {float(k * L.x / 2),
                                float(k * L.y / 2),
                                float(k * L.z / 2),
                                float(k / 2 + o),
                                float(k * V.x / 2),
                                float(k * V.y / 2),
                                float(k * V.z / 2),
                                float(k / 2 + o),
                                0,
                                0,
                                0,
                                0,
                                0,
                                0,
                                0,
                                1};
      const int lobes = m.second_active() && !opt.plain && !fiber ? 2 : 1;
      for (int lobe = 0; lobe < lobes; ++lobe) {
        begin_pass();
        glUseProgram(p_aniso);
        if (fiber) {
          glActiveTexture(GL_TEXTURE2);
          glBindTexture(GL_TEXTURE_2D_ARRAY, texG);
          glActiveTexture(GL_TEXTURE3);
          glBindTexture(GL_TEXTURE_2D_ARRAY, texF);
          glActiveTexture(GL_TEXTURE4);
          glBindTexture(GL_TEXTURE_2D, texMap);
          glUniform1i(glGetUniformLocation(p_aniso, "uG"), 2);
          glUniform1i(glGetUniformLocation(p_aniso, "uF"), 3);
          glUniform1i(glGetUniformLocation(p_aniso, "uMap"), 4);
          glUniform1i(glGetUniformLocation(p_aniso, "uNphi"), fb.nphi);
          glUniform1i(glGetUniformLocation(p_aniso, "uNs"), fb.ns);
          glUniform1i(glGetUniformLocation(p_aniso, "uNk"), fb.nk);
          // The shader's copy of s_at (models/topology.h): one branch per topology source.
          const int topo = s_map_ref ? 3 : map_ref ? 2 : m.topology_as<MathematicalS>() ? 1 : 0;
          glUniform1i(glGetUniformLocation(p_aniso, "uTopo"), topo);
          glUniform1f(glGetUniformLocation(p_aniso, "uS0"), float(m.uniform_s()));
          glUniform1f(glGetUniformLocation(p_aniso, "uAmp"),
                      float(map_ref ? map_ref->amplitude : 0.0));
          set3(p_aniso, "uV", V);
        }
        setm(p_aniso, "uViewProj", view_proj);
        setm(p_aniso, "uTexMat", texmat);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, texD);
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_2D, texS);
        glUniform1i(glGetUniformLocation(p_aniso, "uD"), 0);
        glUniform1i(glGetUniformLocation(p_aniso, "uS"), 1);
        set3(p_aniso, "uL", L);
        set3(p_aniso, "uE", Vec3(1, 1, 1));
        set3(p_aniso, "uKd", m.kd);
        set3(p_aniso, "uKs", m.ks);
        const double wgt =
            m.second_active() ? (lobe == 0 ? m.second_weight : 1 - m.second_weight) : 1.0;
        glUniform1f(glGetUniformLocation(p_aniso, "uWeight"), float(wgt));
        glUniform1i(glGetUniformLocation(p_aniso, "uUseT2"), lobe);
        glUniform1i(glGetUniformLocation(p_aniso, "uAngleIndex"), angle ? 1 : 0);
        glUniform1f(glGetUniformLocation(p_aniso, "uTexels"), float(tables.size));
        glDrawElements(GL_TRIANGLES, nidx, GL_UNSIGNED_INT, nullptr);
      }
      if (m.isotropic_active() && !opt.plain) {
        begin_pass();
        glUseProgram(p_iso);
        setm(p_iso, "uViewProj", view_proj);
        set3(p_iso, "uL", L);
        set3(p_iso, "uV", V);
        set3(p_iso, "uE", Vec3(1, 1, 1));
        set3(p_iso, "uKd", m.iso_kd);
        set3(p_iso, "uKs", m.iso_ks);
        glUniform1f(glGetUniformLocation(p_iso, "uN"), float(m.iso_n));
        glDrawElements(GL_TRIANGLES, nidx, GL_UNSIGNED_INT, nullptr);
      }
    }
    glFinish();
  }
  res.seconds_per_frame =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() /
      std::max(1, opt.repeat);
  res.rgb = read_attachment(0, w, h);

  // Coverage and, when asked, the direct evaluation at the same fragments.
  const GLuint p_g = program(kVertex, kGBuffer);
  const GLenum three[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
  glDrawBuffers(3, three);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glUseProgram(p_g);
  setm(p_g, "uViewProj", view_proj);
  glUniform1i(glGetUniformLocation(p_g, "uFiber"), fiber ? 1 : 0);
  glDrawElements(GL_TRIANGLES, nidx, GL_UNSIGNED_INT, nullptr);
  glFinish();
  const Image gN = read_attachment(0, w, h), gT = read_attachment(1, w, h),
              gT2 = read_attachment(2, w, h);
  res.covered.assign(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      res.covered[static_cast<size_t>(y) * w + x] =
          (gN.at(x, y, 0) != 0 || gN.at(x, y, 1) != 0 || gN.at(x, y, 2) != 0);
  if (opt.reference && fiber) {
    // Against the full model (exact) and against the same tables evaluated on the CPU.
    res.reference = Image(w, h, 3);
    TopologyMap map;
    map.h = opt.topology_map;
    Material line_only = m;
    line_only.model = Model::kLine;
    res.error_bound = opt.light_dirs.size() * fb.max_abs_error + 1e-5;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if (!res.covered[static_cast<size_t>(y) * w + x]) continue;
        const Vec3 N{gN.at(x, y, 0), gN.at(x, y, 1), gN.at(x, y, 2)},
            T{gT.at(x, y, 0), gT.at(x, y, 1), gT.at(x, y, 2)};
        SurfacePoint sp;
        if (!make_frame(Vec3(0, 0, 0), N, T, &sp)) continue;
        const double u = gT2.at(x, y, 0), v = gT2.at(x, y, 1), smath = gT2.at(x, y, 2);
        const double mv = s_map_ref       ? sample_first_channel(opt.s_map, u, v)
                          : map.h.empty() ? 0.0
                                          : map.sample(u, v);
        const double s = s_at(m, smath, mv);
        double exact[3] = {0, 0, 0}, baked[3] = {0, 0, 0};
        for (const Vec3& ld : opt.light_dirs) {
          const LocalDir Ll = to_local(sp, normalize(ld)), Vl = to_local(sp, V);
          LineParamsT<double> p = line_params(m);
          p.psi = 0;
          double f[3], g[3];
          fiber_reflectance(p, s, Ll, Vl, FiberAccuracy{}, f);
          fiber_baked_eval(line_only, tables, fb, Ll, Vl, s, g);
          for (int ch = 0; ch < 3; ++ch) exact[ch] += f[ch], baked[ch] += g[ch];
        }
        for (int ch = 0; ch < 3; ++ch) {
          res.reference.at(x, y, ch) = float(exact[ch]);
          res.max_abs_diff =
              std::max(res.max_abs_diff, std::abs(double(res.rgb.at(x, y, ch)) - exact[ch]));
          res.max_abs_diff_baked =
              std::max(res.max_abs_diff_baked, std::abs(double(res.rgb.at(x, y, ch)) - baked[ch]));
        }
      }
  }
  if (opt.reference && !opt.plain && !fiber) {
    res.reference = Image(w, h, 3);
    // Largest change between neighbouring texels, times the 8-bit sub-texel weight precision
    // that hardware filtering is allowed (and llvmpipe uses): what GL_LINEAR may add to the bake's
    // own (measured) interpolation error.
    double max_step = 0;
    for (int j = 0; j < tables.size; ++j)
      for (int i = 0; i + 1 < tables.size; ++i)
        for (int ch = 0; ch < 3; ++ch) {
          max_step = std::max(max_step, double(std::abs(tables.combined.at(i + 1, j, ch) -
                                                        tables.combined.at(i, j, ch))));
          max_step = std::max(max_step, double(std::abs(tables.combined.at(j, i + 1, ch) -
                                                        tables.combined.at(j, i, ch))));
        }
    constexpr double kFilterWeightStep = 1.0 / 256.0, kFloatSlack = 1e-5;
    // The angle index's acos in single precision: near |x| = 1 an input rounding of 2^-24 moves
    // acos by up to sqrt(2 * 2^-24) = 3.5e-4 rad, i.e. that many texels times (N - 1) / pi.
    const double acos_texels =
        angle ? std::sqrt(2.0 * std::ldexp(1.0, -24)) * (tables.size - 1) / M_PI : 0.0;
    const int lobes = m.second_active() ? 2 : 1;
    res.error_bound =
        opt.light_dirs.size() * lobes *
            (tables.max_abs_error + 2 * max_step * (kFilterWeightStep + acos_texels)) +
        kFloatSlack;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if (!res.covered[static_cast<size_t>(y) * w + x]) continue;
        const Vec3 N{gN.at(x, y, 0), gN.at(x, y, 1), gN.at(x, y, 2)},
            T{gT.at(x, y, 0), gT.at(x, y, 1), gT.at(x, y, 2)};
        const Vec3 T2{gT2.at(x, y, 0), gT2.at(x, y, 1), gT2.at(x, y, 2)};
        SurfacePoint sp;
        if (!make_frame(Vec3(0, 0, 0), N, T, &sp)) continue;
        // In the frame (U = T) the fiber angle is 0 and the second fiber sits at atan2(<T2,W>,
        // <T2,T>).
        Material local = m;
        local.fiber_angle_deg = 0;
        local.second_angle_deg = rad_to_deg(std::atan2(dot(T2, sp.W), dot(T2, sp.U)));
        const Evaluator le(local);
        double acc[3] = {0, 0, 0};
        for (const Vec3& ld : opt.light_dirs) {
          double f[3];
          le(to_local(sp, normalize(ld)), to_local(sp, V), f);
          for (int ch = 0; ch < 3; ++ch) acc[ch] += f[ch];
        }
        for (int ch = 0; ch < 3; ++ch) {
          res.reference.at(x, y, ch) = float(acc[ch]);
          res.max_abs_diff =
              std::max(res.max_abs_diff, std::abs(double(res.rgb.at(x, y, ch)) - acc[ch]));
        }
      }
  }
  glDeleteProgram(p_aniso);
  glDeleteProgram(p_iso);
  glDeleteProgram(p_g);
  glDeleteTextures(1, &texD);
  if (texG) glDeleteTextures(1, &texG);
  if (texF) glDeleteTextures(1, &texF);
  if (texMap) glDeleteTextures(1, &texMap);
  glDeleteTextures(1, &texS);
  glDeleteTextures(3, color);
  glDeleteRenderbuffers(1, &depth);
  glDeleteFramebuffers(1, &fbo);
  glDeleteBuffers(1, &vbo);
  glDeleteBuffers(1, &ibo);
  glDeleteVertexArrays(1, &vao);
  return res;
}

}  // namespace aniso
