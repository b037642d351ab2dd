// Small OpenGL helpers of the viewer (GL 3.3 core through libepoxy, windows through GLFW 3.3):
// a context (visible window, or a hidden one for offscreen rendering under Xvfb/Mesa), owners of
// GL objects, program compilation with readable errors, framebuffers.
//
// Every GL object of the viewer lives in a GlHandle (below): move-only, deleted when the handle is
// destroyed or reset. GL objects must be deleted while their context is current, so everything
// holding handles (the Renderer, its modes, meshes, framebuffers) is destroyed before the
// GlContext (viewer/app.cc declares the context first; the tests delete it last).
#ifndef SHRM_VIEWER_GL_UTIL_H_
#define SHRM_VIEWER_GL_UTIL_H_

#include <epoxy/gl.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

struct GLFWwindow;

namespace shrm::viewer {

// The kinds of GL objects: how one name is generated (glGen*, where GL has it) and deleted.
namespace gl_kind {
struct Texture {
  static GLuint Generate() {
    GLuint id = 0;
    glGenTextures(1, &id);
    return id;
  }
  static void Delete(GLuint id) { glDeleteTextures(1, &id); }
};
struct Buffer {
  static GLuint Generate() {
    GLuint id = 0;
    glGenBuffers(1, &id);
    return id;
  }
  static void Delete(GLuint id) { glDeleteBuffers(1, &id); }
};
struct VertexArray {
  static GLuint Generate() {
    GLuint id = 0;
    glGenVertexArrays(1, &id);
    return id;
  }
  static void Delete(GLuint id) { glDeleteVertexArrays(1, &id); }
};
struct Framebuffer {
  static GLuint Generate() {
    GLuint id = 0;
    glGenFramebuffers(1, &id);
    return id;
  }
  static void Delete(GLuint id) { glDeleteFramebuffers(1, &id); }
};
struct Renderbuffer {
  static GLuint Generate() {
    GLuint id = 0;
    glGenRenderbuffers(1, &id);
    return id;
  }
  static void Delete(GLuint id) { glDeleteRenderbuffers(1, &id); }
};
// Created with glCreateProgram / glCreateShader(type): wrap the name, GlProgram(glCreateProgram()).
struct Program {
  static void Delete(GLuint id) { glDeleteProgram(id); }
};
struct Shader {
  static void Delete(GLuint id) { glDeleteShader(id); }
};
}  // namespace gl_kind

// The owner of one GL object name of kind K (gl_kind above); 0 = none. Move-only, like
// std::unique_ptr: get() the name, reset() deletes it (and takes another), release() gives it up.
template <typename K>
class GlHandle {
 public:
  GlHandle() = default;
  explicit GlHandle(GLuint id) : id_(id) {}
  ~GlHandle() { reset(); }
  GlHandle(GlHandle&& other) noexcept : id_(other.release()) {}
  GlHandle& operator=(GlHandle&& other) noexcept {
    if (this != &other) reset(other.release());
    return *this;
  }
  GlHandle(const GlHandle&) = delete;
  GlHandle& operator=(const GlHandle&) = delete;

  // A new object (glGen*; kinds without glGen* are constructed from their name).
  static GlHandle Generate() { return GlHandle(K::Generate()); }

  GLuint get() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  void reset(GLuint id = 0) {
    if (id_ != 0 && id_ != id) K::Delete(id_);
    id_ = id;
  }
  [[nodiscard]] GLuint release() {
    const GLuint id = id_;
    id_ = 0;
    return id;
  }

 private:
  GLuint id_ = 0;
};

using GlTexture = GlHandle<gl_kind::Texture>;
using GlBuffer = GlHandle<gl_kind::Buffer>;
using GlVertexArray = GlHandle<gl_kind::VertexArray>;
using GlFramebuffer = GlHandle<gl_kind::Framebuffer>;
using GlRenderbuffer = GlHandle<gl_kind::Renderbuffer>;
using GlProgram = GlHandle<gl_kind::Program>;
using GlShader = GlHandle<gl_kind::Shader>;

// GLFW + one window with a current GL 3.3 (or later) core context. Hidden windows render only
// into framebuffer objects (headless screenshots, benchmarks, tests).
class GlContext {
 public:
  // Errors (Unavailable): no display (run under `xvfb-run -a`), no GL 3.3 core context; the
  // message carries what GLFW reported.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<GlContext>> Create(int width, int height,
                                                                         bool visible,
                                                                         const std::string& title);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  GLFWwindow* window() const { return window_; }
  // "OpenGL 4.5 (Core Profile) Mesa 22.3.6, llvmpipe (LLVM 15.0.6, 256 bits)".
  std::string Describe() const;

 private:
  GlContext() = default;
  GLFWwindow* window_ = nullptr;
};

// Where GLFW's errors go outside GlContext::Create() (whose own failures carry them in their
// status): the program's error path (viewer/app.cc); nullptr (and the default) is PrintError of
// viewer/error_report.h.
void SetGlfwErrorHandler(std::function<void(const absl::Status&)> handler);

// Compiles and links a program; errors name `what` and carry the info logs.
[[nodiscard]] absl::StatusOr<GlProgram> BuildProgram(const std::string& vertex,
                                                     const std::string& fragment,
                                                     const std::string& what);

// The vertex shader of full-screen passes (draw 3 vertices with an empty VAO): clip-space
// triangle covering the viewport, `v_ndc` in [-1, 1]^2.
extern const char kFullscreenVertexShader[];

// A framebuffer with colour attachments of the given internal formats (GL_RGBA32F, GL_RGBA8,
// ...) and a depth renderbuffer. Errors: incomplete framebuffer.
class Framebuffer {
 public:
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<Framebuffer>> Create(
      int width, int height, const std::vector<GLenum>& formats);
  GLuint id() const { return fbo_.get(); }
  GLuint color(int i) const { return colors_[i].get(); }
  int width() const { return width_; }
  int height() const { return height_; }
  // Reads attachment i as float RGBA, rows from the TOP (flipped from GL's bottom-up).
  std::vector<float> ReadRgba(int i) const;

 private:
  Framebuffer() = default;
  // Destroyed in reverse order: the colour textures, the depth renderbuffer, the framebuffer.
  GlFramebuffer fbo_;
  GlRenderbuffer depth_;
  std::vector<GlTexture> colors_;
  int width_ = 0, height_ = 0;
};

// Uniform helpers (the program must be in use).
void SetUniform(GLuint program, const char* name, int value);
void SetUniform(GLuint program, const char* name, float value);
void SetUniform(GLuint program, const char* name, float x, float y, float z);
void SetUniformMat4(GLuint program, const char* name, const float* column_major);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_GL_UTIL_H_
