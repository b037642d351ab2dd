#include "viewer/gl_util.h"

#include <epoxy/gl.h>
// GLFW without its own GL header (libepoxy provides GL).
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "viewer/error_report.h"

namespace shrm::viewer {
namespace {

std::string ShaderLog(GLuint shader) {
  GLint len = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &len);
  std::string log(len > 0 ? len : 1, '\0');
  glGetShaderInfoLog(shader, len, nullptr, log.data());
  return log;
}

absl::StatusOr<GlShader> Compile(GLenum type, const std::string& source, const std::string& what) {
  GlShader s(glCreateShader(type));
  const char* src = source.c_str();
  glShaderSource(s.get(), 1, &src, nullptr);
  glCompileShader(s.get());
  GLint ok = 0;
  glGetShaderiv(s.get(), GL_COMPILE_STATUS, &ok);
  if (!ok) {
    return absl::InternalError(absl::StrCat(what, ": ",
                                            type == GL_VERTEX_SHADER ? "vertex" : "fragment",
                                            " shader does not compile:\n", ShaderLog(s.get())));
  }
  return s;
}

int glfw_users = 0;

// GLFW's errors: collected while GlContext::Create() runs (its status carries them), passed to
// the handler otherwise.
void PrintStatus(const absl::Status& s) { PrintError(s.message()); }
std::function<void(const absl::Status&)>& GlfwErrorHandler() {
  static std::function<void(const absl::Status&)> handler = PrintStatus;
  return handler;
}
bool collecting_glfw_errors = false;
std::string collected_glfw_errors;

void OnGlfwError(int code, const char* message) {
  const std::string text = absl::StrFormat("GLFW error %d: %s", code, message);
  if (collecting_glfw_errors) {
    absl::StrAppend(&collected_glfw_errors, collected_glfw_errors.empty() ? "" : "; ", text);
  } else {
    GlfwErrorHandler()(absl::UnknownError(text));
  }
}

// The failure of Create() with what GLFW said.
absl::Status ContextError(const std::string& what) {
  return absl::UnavailableError(
      collected_glfw_errors.empty() ? what : absl::StrCat(what, " (", collected_glfw_errors, ")"));
}

}  // namespace

void SetGlfwErrorHandler(std::function<void(const absl::Status&)> handler) {
  GlfwErrorHandler() = handler ? std::move(handler) : PrintStatus;
}

const char kFullscreenVertexShader[] = R"(#version 330 core
out vec2 v_ndc;
void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  v_ndc = p;
  gl_Position = vec4(p, 1.0, 1.0);
}
)";

absl::StatusOr<std::unique_ptr<GlContext>> GlContext::Create(int width, int height, bool visible,
                                                             const std::string& title) {
  glfwSetErrorCallback(OnGlfwError);
  collecting_glfw_errors = true;
  collected_glfw_errors.clear();
  struct StopCollecting {
    ~StopCollecting() { collecting_glfw_errors = false; }
  } stop_collecting;
  if (glfw_users == 0 && !glfwInit()) {
    return ContextError("cannot initialize GLFW: no display? (headless: run under `xvfb-run -a`)");
  }
  ++glfw_users;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, visible ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_SAMPLES, 0);
  std::unique_ptr<GlContext> ctx(new GlContext());
  ctx->window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (ctx->window_ == nullptr) {
    return ContextError("cannot create a window with an OpenGL 3.3 core context");
  }
  glfwMakeContextCurrent(ctx->window_);
  glfwSwapInterval(visible ? 1 : 0);
  // Errors GLFW reported although the context works: to the handler.
  collecting_glfw_errors = false;
  if (!collected_glfw_errors.empty()) GlfwErrorHandler()(absl::UnknownError(collected_glfw_errors));
  return ctx;
}

GlContext::~GlContext() {
  if (window_ != nullptr) glfwDestroyWindow(window_);
  if (--glfw_users == 0) glfwTerminate();
}

std::string GlContext::Describe() const {
  return absl::StrCat("OpenGL ", reinterpret_cast<const char*>(glGetString(GL_VERSION)), ", ",
                      reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
}

absl::StatusOr<GlProgram> BuildProgram(const std::string& vertex, const std::string& fragment,
                                       const std::string& what) {
  SHRM_ASSIGN_OR_RETURN(GlShader vs, Compile(GL_VERTEX_SHADER, vertex, what));
  SHRM_ASSIGN_OR_RETURN(GlShader fs, Compile(GL_FRAGMENT_SHADER, fragment, what));
  GlProgram p(glCreateProgram());
  glAttachShader(p.get(), vs.get());
  glAttachShader(p.get(), fs.get());
  glLinkProgram(p.get());
  // vs and fs are deleted on return; GL keeps them as long as the program holds them.
  GLint ok = 0;
  glGetProgramiv(p.get(), GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetProgramiv(p.get(), GL_INFO_LOG_LENGTH, &len);
    std::string log(len > 0 ? len : 1, '\0');
    glGetProgramInfoLog(p.get(), len, nullptr, log.data());
    return absl::InternalError(absl::StrCat(what, ": program does not link:\n", log));
  }
  return p;
}

absl::StatusOr<std::unique_ptr<Framebuffer>> Framebuffer::Create(
    int width, int height, const std::vector<GLenum>& formats) {
  std::unique_ptr<Framebuffer> fb(new Framebuffer());
  fb->width_ = width;
  fb->height_ = height;
  fb->fbo_ = GlFramebuffer::Generate();
  glBindFramebuffer(GL_FRAMEBUFFER, fb->fbo_.get());
  std::vector<GLenum> buffers;
  for (size_t i = 0; i < formats.size(); ++i) {
    GlTexture tex = GlTexture::Generate();
    glBindTexture(GL_TEXTURE_2D, tex.get());
    const bool is_float = formats[i] == GL_RGBA32F || formats[i] == GL_RGBA16F;
    glTexImage2D(GL_TEXTURE_2D, 0, formats[i], width, height, 0, GL_RGBA,
                 is_float ? GL_FLOAT : GL_UNSIGNED_BYTE, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D, tex.get(), 0);
    fb->colors_.push_back(std::move(tex));
    buffers.push_back(GL_COLOR_ATTACHMENT0 + i);
  }
  glDrawBuffers(static_cast<GLsizei>(buffers.size()), buffers.data());
  fb->depth_ = GlRenderbuffer::Generate();
  glBindRenderbuffer(GL_RENDERBUFFER, fb->depth_.get());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, fb->depth_.get());
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    return absl::InternalError(absl::StrCat("framebuffer ", width, " x ", height,
                                            " is incomplete (status 0x", absl::Hex(status), ")"));
  }
  return fb;
}

std::vector<float> Framebuffer::ReadRgba(int i) const {
  std::vector<float> raw(static_cast<size_t>(width_) * height_ * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_.get());
  glReadBuffer(GL_COLOR_ATTACHMENT0 + i);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, raw.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  std::vector<float> out(raw.size());
  const size_t row = static_cast<size_t>(width_) * 4;
  for (int y = 0; y < height_; ++y)
    std::copy(raw.begin() + (height_ - 1 - y) * row, raw.begin() + (height_ - y) * row,
              out.begin() + y * row);
  return out;
}

void SetUniform(GLuint program, const char* name, int value) {
  glUniform1i(glGetUniformLocation(program, name), value);
}
void SetUniform(GLuint program, const char* name, float value) {
  glUniform1f(glGetUniformLocation(program, name), value);
}
void SetUniform(GLuint program, const char* name, float x, float y, float z) {
  glUniform3f(glGetUniformLocation(program, name), x, y, z);
}
void SetUniformMat4(GLuint program, const char* name, const float* column_major) {
  glUniformMatrix4fv(glGetUniformLocation(program, name), 1, GL_FALSE, column_major);
}

}  // namespace shrm::viewer
