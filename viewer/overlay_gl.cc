#include "viewer/overlay_gl.h"

#include "core/base/status_macros.h"
#include "viewer/gl_util.h"
#include "viewer/text_overlay.h"

namespace shrm::viewer {
namespace {

// Drawn with the viewport set to the overlay's rectangle: the full-screen triangle covers it and
// each fragment fetches its texel (the texture's row 0 is the TOP row of the text).
constexpr char kOverlayFragment[] = R"(#version 330 core
uniform sampler2D u_text;
uniform int u_x0, u_y0, u_height;  // viewport origin (GL, bottom-left) and texture height
out vec4 o_color;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy) - ivec2(u_x0, u_y0);
  o_color = texelFetch(u_text, ivec2(p.x, u_height - 1 - p.y), 0);
}
)";

}  // namespace

absl::StatusOr<std::unique_ptr<OverlayGl>> OverlayGl::Create() {
  std::unique_ptr<OverlayGl> o(new OverlayGl());
  SHRM_ASSIGN_OR_RETURN(o->program_,
                        BuildProgram(kFullscreenVertexShader, kOverlayFragment, "text overlay"));
  o->texture_ = GlTexture::Generate();
  glBindTexture(GL_TEXTURE_2D, o->texture_.get());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glBindTexture(GL_TEXTURE_2D, 0);
  o->vao_ = GlVertexArray::Generate();
  return o;
}

void OverlayGl::Draw(const std::vector<std::string>& lines, int scale, int margin, int width,
                     int height) {
  if (lines.empty()) return;
  if (lines != lines_ || scale != scale_) {
    const OverlayImage img = RasterizeOverlay(lines, scale);
    glBindTexture(GL_TEXTURE_2D, texture_.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, img.width, img.height, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                 img.rgba.data());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    lines_ = lines;
    scale_ = scale;
    tex_width_ = img.width;
    tex_height_ = img.height;
  }
  if (tex_width_ == 0 || tex_height_ == 0) return;
  const int x0 = margin, y0 = height - margin - tex_height_;
  glViewport(x0, y0, tex_width_, tex_height_);
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
  const GLuint program = program_.get();
  glUseProgram(program);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, texture_.get());
  SetUniform(program, "u_text", 0);
  SetUniform(program, "u_x0", x0);
  SetUniform(program, "u_y0", y0);
  SetUniform(program, "u_height", tex_height_);
  glBindVertexArray(vao_.get());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glUseProgram(0);
  glDisable(GL_BLEND);
  glViewport(0, 0, width, height);
}

}  // namespace shrm::viewer
