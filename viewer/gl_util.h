// Small OpenGL helpers of the viewer (GL 3.3 core through libepoxy, windows through GLFW 3.3):
// a context (visible window, or a hidden one for offscreen rendering under Xvfb/Mesa), program
// compilation with readable errors, textures and framebuffers.
#ifndef SHRM_VIEWER_GL_UTIL_H_
#define SHRM_VIEWER_GL_UTIL_H_

#include <epoxy/gl.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

struct GLFWwindow;

namespace shrm::viewer {

// GLFW + one window with a current GL 3.3 (or later) core context. Hidden windows render only
// into framebuffer objects (headless screenshots, benchmarks, tests).
class GlContext {
 public:
  // Errors (Unavailable): no display (run under `xvfb-run -a`), no GL 3.3 core context.
  static absl::StatusOr<std::unique_ptr<GlContext>> Create(int width, int height, bool visible,
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

// Compiles and links a program; errors name `what` and carry the info logs.
absl::StatusOr<GLuint> BuildProgram(const std::string& vertex, const std::string& fragment,
                                    const std::string& what);

// The vertex shader of full-screen passes (draw 3 vertices with an empty VAO): clip-space
// triangle covering the viewport, `v_ndc` in [-1, 1]^2.
extern const char kFullscreenVertexShader[];

// A framebuffer with colour attachments of the given internal formats (GL_RGBA32F, GL_RGBA8,
// ...) and a depth renderbuffer. Errors: incomplete framebuffer.
class Framebuffer {
 public:
  static absl::StatusOr<std::unique_ptr<Framebuffer>> Create(int width, int height,
                                                             const std::vector<GLenum>& formats);
  ~Framebuffer();
  GLuint id() const { return fbo_; }
  GLuint color(int i) const { return colors_[i]; }
  int width() const { return width_; }
  int height() const { return height_; }
  // Reads attachment i as float RGBA, rows from the TOP (flipped from GL's bottom-up).
  std::vector<float> ReadRgba(int i) const;

 private:
  Framebuffer() = default;
  GLuint fbo_ = 0, depth_ = 0;
  std::vector<GLuint> colors_;
  int width_ = 0, height_ = 0;
};

// Uniform helpers (the program must be in use).
void SetUniform(GLuint program, const char* name, int value);
void SetUniform(GLuint program, const char* name, float value);
void SetUniform(GLuint program, const char* name, float x, float y, float z);
void SetUniformMat4(GLuint program, const char* name, const float* column_major);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_GL_UTIL_H_
