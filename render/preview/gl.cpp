#include "render/preview/gl.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "core/error.h"

namespace aniso::gl {

namespace {

std::string hex(EGLint v) {
  char b[16];
  std::snprintf(b, sizeof b, "%x", v);
  return b;
}

// Throws with the driver's log when `status` of the shader or program is false (and deletes it).
template <class GetIv, class GetLog, class Delete>
void check_status(GLuint id, GLenum status, GetIv get_iv, GetLog get_log, Delete del,
                  const std::string& what) {
  GLint ok = 0;
  get_iv(id, status, &ok);
  if (ok) return;
  char log[2048] = "";
  get_log(id, sizeof log, nullptr, log);
  del(id);
  throw Error("preview: " + what + ": " + log);
}

GLuint compile(GLenum type, const char* src, const char* name) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  check_status(s, GL_COMPILE_STATUS, glGetShaderiv, glGetShaderInfoLog, glDeleteShader,
               std::string("shader compile error in ") + name);
  return s;
}

// Which renderer ANISO_GL asks for: "auto" (unset), "gpu" or "software" (Context's constructor
// says what each takes). Throws on anything else.
std::string renderer_wanted() {
  const char* env = std::getenv("ANISO_GL");
  const std::string want = env && *env ? env : "auto";
  if (want != "auto" && want != "gpu" && want != "software")
    throw Error("ANISO_GL=" + want + ": expected auto, gpu or software");
  return want;
}

// One of EGL's devices (EGL_EXT_device_base, or its parts EGL_EXT_device_enumeration and
// EGL_EXT_device_query, with EGL_EXT_platform_device): the first GPU (a device other than Mesa's
// software renderer) or, with `software`, Mesa's software renderer (llvmpipe); EGL_NO_DEVICE_EXT
// where EGL lists none.
EGLDeviceEXT egl_device(bool software) {
  const bool devices = epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_device_base") ||
                       (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_device_enumeration") &&
                        epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_device_query"));
  if (!devices || !epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_device"))
    return EGL_NO_DEVICE_EXT;
  EGLDeviceEXT list[16];
  EGLint n = 0;
  if (!eglQueryDevicesEXT(16, list, &n)) return EGL_NO_DEVICE_EXT;
  for (EGLint i = 0; i < n; ++i) {
    const char* ext = eglQueryDeviceStringEXT(list[i], EGL_EXTENSIONS);
    const bool is_software = ext && std::strstr(ext, "EGL_MESA_device_software");
    if (is_software == software) return list[i];
  }
  return EGL_NO_DEVICE_EXT;
}

}  // namespace

Context::Context() {
  // ANISO_GL (renderer_wanted): "gpu" and "software" take that EGL device or fail; "auto" takes a
  // GPU's device where EGL lists one, else (or where it cannot give the context) the surfaceless
  // platform, whatever driver serves it (Mesa: a GPU's render node or llvmpipe; NVIDIA's too).
  const std::string want = renderer_wanted();
  const bool software = want == "software";
  std::string device_error;
  if (const EGLDeviceEXT device = egl_device(software); device == EGL_NO_DEVICE_EXT) {
    device_error =
        software ? "EGL lists no software renderer (Mesa's llvmpipe)" : "EGL lists no GPU device";
  } else {
    dpy_ = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, device, nullptr);
    device_error = dpy_ == EGL_NO_DISPLAY ? "no display on the EGL device" : open();
    if (device_error.empty()) return;
    device_error = "the EGL device: " + device_error + " (EGL error 0x" + hex(eglGetError()) + ")";
    release();
  }
  if (want != "auto") fail("ANISO_GL=" + want + ": " + device_error);
  const std::string gpu_error = "; " + device_error;
  if (!epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless"))
    fail("EGL_MESA_platform_surfaceless is not available" + gpu_error);
  dpy_ = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (dpy_ == EGL_NO_DISPLAY) fail("no surfaceless EGL display" + gpu_error);
  const std::string error = open();
  if (!error.empty()) fail(error + gpu_error);
}

std::string Context::open() {
  EGLint major = 0, minor = 0;
  if (!eglInitialize(dpy_, &major, &minor)) return "eglInitialize failed";
  if (!eglBindAPI(EGL_OPENGL_API)) return "eglBindAPI(OpenGL) failed";
  const EGLint cfg_attr[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig cfg;
  EGLint n = 0;
  if (!eglChooseConfig(dpy_, cfg_attr, &cfg, 1, &n) || n < 1) return "no EGL config with OpenGL";
  const EGLint ctx_attr[] = {EGL_CONTEXT_MAJOR_VERSION,
                             3,
                             EGL_CONTEXT_MINOR_VERSION,
                             3,
                             EGL_CONTEXT_OPENGL_PROFILE_MASK,
                             EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                             EGL_NONE};
  ctx_ = eglCreateContext(dpy_, cfg, EGL_NO_CONTEXT, ctx_attr);
  if (ctx_ == EGL_NO_CONTEXT) return "cannot create an OpenGL 3.3 core context";
  if (!eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx_)) return "eglMakeCurrent failed";
  return "";
}

Context::~Context() { release(); }

void Context::release() {
  if (dpy_ == EGL_NO_DISPLAY) return;
  eglMakeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (ctx_ != EGL_NO_CONTEXT) eglDestroyContext(dpy_, ctx_);
  eglTerminate(dpy_);
  dpy_ = EGL_NO_DISPLAY;
  ctx_ = EGL_NO_CONTEXT;
}

void Context::fail(const std::string& what) {
  const std::string msg =
      "preview: cannot create a headless OpenGL context (EGL, ANISO_GL=auto|gpu|software): " +
      what + " (EGL error 0x" + hex(eglGetError()) + ")";
  release();  // a constructor that throws runs no destructor
  throw Error(msg);
}

Program::Program(const char* vertex, const char* fragment, const char* name) {
  GLuint a = compile(GL_VERTEX_SHADER, vertex, name);
  GLuint b = 0;
  try {
    b = compile(GL_FRAGMENT_SHADER, fragment, name);
  } catch (...) {
    glDeleteShader(a);
    throw;
  }
  id_ = glCreateProgram();
  glAttachShader(id_, a);
  glAttachShader(id_, b);
  glLinkProgram(id_);
  glDeleteShader(a);
  glDeleteShader(b);
  check_status(id_, GL_LINK_STATUS, glGetProgramiv, glGetProgramInfoLog, glDeleteProgram,
               std::string("shader link error in ") + name);
}

void Program::set(const char* u, const Vec3& v) const {
  glUniform3f(glGetUniformLocation(id_, u), float(v.x), float(v.y), float(v.z));
}
void Program::set(const char* u, const RGB& v) const {
  glUniform3f(glGetUniformLocation(id_, u), float(v[0]), float(v[1]), float(v[2]));
}
void Program::set(const char* u, float v) const { glUniform1f(glGetUniformLocation(id_, u), v); }
void Program::set(const char* u, int v) const { glUniform1i(glGetUniformLocation(id_, u), v); }
void Program::set_matrix(const char* u, const float* m) const {
  glUniformMatrix4fv(glGetUniformLocation(id_, u), 1, GL_TRUE, m);
}

namespace {
void set_filtering(GLenum target, GLint wrap) {
  glTexParameteri(target, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(target, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(target, GL_TEXTURE_WRAP_S, wrap);
  glTexParameteri(target, GL_TEXTURE_WRAP_T, wrap);
}
}  // namespace

void Texture::table(const Image& t) {
  target_ = GL_TEXTURE_2D;
  glGenTextures(1, &id_);
  glBindTexture(target_, id_);
  glTexImage2D(target_, 0, GL_R32F, t.width, t.height, 0, GL_RED, GL_FLOAT, t.px.data());
  set_filtering(target_, GL_CLAMP_TO_EDGE);
}

void Texture::map(const Image& img) {
  std::vector<float> first(static_cast<size_t>(img.width) * img.height);
  for (size_t p = 0; p < first.size(); ++p) first[p] = img.px[p * img.channels];
  target_ = GL_TEXTURE_2D;
  glGenTextures(1, &id_);
  glBindTexture(target_, id_);
  glTexImage2D(target_, 0, GL_R32F, img.width, img.height, 0, GL_RED, GL_FLOAT, first.data());
  set_filtering(target_, GL_REPEAT);
}

void Texture::array(const std::vector<float>& data, int w, int h, int layers) {
  target_ = GL_TEXTURE_2D_ARRAY;
  glGenTextures(1, &id_);
  glBindTexture(target_, id_);
  glTexImage3D(target_, 0, GL_R32F, w, h, layers, 0, GL_RED, GL_FLOAT, data.data());
  set_filtering(target_, GL_CLAMP_TO_EDGE);
}

void Texture::volume_rgb(const std::vector<float>& data, int w, int h, int d) {
  target_ = GL_TEXTURE_3D;
  glGenTextures(1, &id_);
  glBindTexture(target_, id_);
  glTexImage3D(target_, 0, GL_RGB32F, w, h, d, 0, GL_RGB, GL_FLOAT, data.data());
  set_filtering(target_, GL_CLAMP_TO_EDGE);
  glTexParameteri(target_, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
  glTexParameteri(target_, GL_TEXTURE_WRAP_S, GL_REPEAT);
}

void Texture::texels(const Image& img) {
  std::vector<float> rgba(static_cast<size_t>(img.width) * img.height * 4, 0.0f);
  for (size_t p = 0; p < rgba.size() / 4; ++p)
    for (int c = 0; c < std::min(img.channels, 4); ++c)
      rgba[p * 4 + c] = img.px[p * img.channels + c];
  target_ = GL_TEXTURE_2D;
  glGenTextures(1, &id_);
  glBindTexture(target_, id_);
  glTexImage2D(target_, 0, GL_RGBA32F, img.width, img.height, 0, GL_RGBA, GL_FLOAT, rgba.data());
  glTexParameteri(target_, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(target_, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
}

void Texture::bind(int unit) const {
  glActiveTexture(GL_TEXTURE0 + unit);
  glBindTexture(target_, id_);
}

MeshBuffers::MeshBuffers(const std::vector<float>& vertices, const std::vector<int>& sizes,
                         const std::vector<uint32_t>& indices)
    : count_(static_cast<GLsizei>(indices.size())) {
  glGenVertexArrays(1, &vao_);
  glBindVertexArray(vao_);
  glGenBuffers(1, &vbo_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, vertices.size() * sizeof(float), vertices.data(), GL_STATIC_DRAW);
  int stride = 0;
  for (int s : sizes) stride += s;
  size_t offset = 0;
  for (size_t a = 0; a < sizes.size(); ++a) {
    glEnableVertexAttribArray(static_cast<GLuint>(a));
    glVertexAttribPointer(static_cast<GLuint>(a), sizes[a], GL_FLOAT, GL_FALSE,
                          stride * static_cast<int>(sizeof(float)),
                          reinterpret_cast<void*>(offset * sizeof(float)));
    offset += sizes[a];
  }
  glGenBuffers(1, &ibo_);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, indices.size() * sizeof(uint32_t), indices.data(),
               GL_STATIC_DRAW);
}

MeshBuffers::~MeshBuffers() {
  glDeleteBuffers(1, &vbo_);
  glDeleteBuffers(1, &ibo_);
  glDeleteVertexArrays(1, &vao_);
}

void MeshBuffers::draw() const {
  glBindVertexArray(vao_);
  glDrawElements(GL_TRIANGLES, count_, GL_UNSIGNED_INT, nullptr);
}

Framebuffer::Framebuffer(int w, int h, int attachments) : w_(w), h_(h), color_(attachments) {
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glGenTextures(attachments, color_.data());
  for (int i = 0; i < attachments; ++i) {
    glBindTexture(GL_TEXTURE_2D, color_[i]);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, nullptr);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D, color_[i], 0);
  }
  glGenRenderbuffers(1, &depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error("preview: float framebuffer incomplete on " +
                std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))));
  glViewport(0, 0, w, h);
}

Framebuffer::~Framebuffer() {
  glDeleteTextures(static_cast<GLsizei>(color_.size()), color_.data());
  glDeleteRenderbuffers(1, &depth_);
  glDeleteFramebuffers(1, &fbo_);
}

void Framebuffer::draw_to(int attachments) const {
  std::vector<GLenum> targets;
  for (int i = 0; i < attachments; ++i) targets.push_back(GL_COLOR_ATTACHMENT0 + i);
  glDrawBuffers(attachments, targets.data());
}

Image Framebuffer::read(int attachment) const {
  std::vector<float> buf(static_cast<size_t>(w_) * h_ * 4);
  glReadBuffer(GL_COLOR_ATTACHMENT0 + attachment);
  glReadPixels(0, 0, w_, h_, GL_RGBA, GL_FLOAT, buf.data());
  Image img(w_, h_, 3);
  for (int y = 0; y < h_; ++y)
    for (int x = 0; x < w_; ++x)
      for (int c = 0; c < 3; ++c)
        img.at(x, y, c) = buf[(static_cast<size_t>(h_ - 1 - y) * w_ + x) * 4 + c];
  return img;
}

}  // namespace aniso::gl
