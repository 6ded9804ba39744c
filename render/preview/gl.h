// render/ internal: the OpenGL plumbing of the preview, apart from what it draws. A headless
// OpenGL 3.3 core context on a GPU's EGL device where EGL lists one, else on EGL's surfaceless
// platform (Mesa: a GPU's render node or llvmpipe); ANISO_GL=gpu or software asks for that device
// or an error. Programs from the embedded GLSL of render/shaders/, float textures and an
// off-screen float framebuffer, each released by its destructor. Included by render/*.cpp only
// (epoxy is a large header).
#pragma once
#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <string>
#include <vector>

#include "core/image.h"
#include "core/vec.h"
#include "models/material.h"

namespace aniso::gl {

class Context {
 public:
  Context();
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

 private:
  // Initializes dpy_ and makes a 3.3 core context current on it: "" or what failed.
  std::string open();
  [[noreturn]] void fail(const std::string& what);
  void release();
  EGLDisplay dpy_ = EGL_NO_DISPLAY;
  EGLContext ctx_ = EGL_NO_CONTEXT;
};

// A linked program; compile and link errors throw with the driver's log and the shader's name.
class Program {
 public:
  Program(const char* vertex, const char* fragment, const char* name);
  ~Program() { glDeleteProgram(id_); }
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;
  GLuint id() const { return id_; }
  void use() const { glUseProgram(id_); }
  void set(const char* uniform, const Vec3& v) const;
  void set(const char* uniform, const RGB& v) const;
  void set(const char* uniform, float v) const;
  void set(const char* uniform, int v) const;
  void set_matrix(const char* uniform, const float* row_major4x4) const;

 private:
  GLuint id_ = 0;
};

// A texture, single channel float (R32F), linear filtering.
class Texture {
 public:
  Texture() = default;
  ~Texture() {
    if (id_) glDeleteTextures(1, &id_);
  }
  Texture(const Texture&) = delete;
  Texture& operator=(const Texture&) = delete;
  // A lookup table: clamped at its edges.
  void table(const Image& t);
  // Channel 0 of a material map over uv: repeated (glTF uv; row 0 is v = 0 = t = 0).
  void map(const Image& img);
  void array(const std::vector<float>& data, int w, int h, int layers);
  // An RGB volume (w x h x d, RGB32F), linear filtering: repeated in s, clamped in t and r
  // (render/bake/environment.h's tables: equirectangular in s, t; levels of b in r).
  void volume_rgb(const std::vector<float>& data, int w, int h, int d);
  // A material map read texel by texel (texelFetch: the shader filters it itself, in float, as
  // the CPU does): up to four channels as RGBA, row 0 at t = 0, no filtering.
  void texels(const Image& img);
  void bind(int unit) const;
  bool empty() const { return id_ == 0; }

 private:
  GLuint id_ = 0;
  GLenum target_ = GL_TEXTURE_2D;
};

// The mesh as interleaved vertex attributes (location i: `sizes[i]` floats) and triangles.
class MeshBuffers {
 public:
  MeshBuffers(const std::vector<float>& vertices, const std::vector<int>& sizes,
              const std::vector<uint32_t>& indices);
  ~MeshBuffers();
  MeshBuffers(const MeshBuffers&) = delete;
  MeshBuffers& operator=(const MeshBuffers&) = delete;
  void draw() const;

 private:
  GLuint vao_ = 0, vbo_ = 0, ibo_ = 0;
  GLsizei count_ = 0;
};

// An off-screen framebuffer: `attachments` float RGBA colour targets and a depth buffer.
class Framebuffer {
 public:
  Framebuffer(int w, int h, int attachments);
  ~Framebuffer();
  Framebuffer(const Framebuffer&) = delete;
  Framebuffer& operator=(const Framebuffer&) = delete;
  void draw_to(int attachments) const;  // the first `attachments` targets
  // Colour target i as a 3-channel image, row 0 at the top.
  Image read(int attachment) const;

 private:
  int w_, h_;
  GLuint fbo_ = 0, depth_ = 0;
  std::vector<GLuint> color_;
};

}  // namespace aniso::gl
