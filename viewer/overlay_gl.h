// The viewer's in-frame text overlay, GL part: the lines rasterized on the CPU
// (viewer/text_overlay.h) in an RGBA8 texture, alpha-blended as a screen-space quad in the
// top-left corner of the bound framebuffer. The texture is rebuilt only when the lines change.
#ifndef SHRM_VIEWER_OVERLAY_GL_H_
#define SHRM_VIEWER_OVERLAY_GL_H_

#include <epoxy/gl.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "viewer/gl_util.h"

namespace shrm::viewer {

class OverlayGl {
 public:
  // GL context must be current (also when it is destroyed: gl_util.h).
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<OverlayGl>> Create();

  // Draws `lines` (scaled by `scale`) into the bound framebuffer of size width x height, its
  // top-left corner `margin` pixels from the top-left of the frame. Nothing without lines.
  // Leaves blending disabled and the viewport at the full frame.
  void Draw(const std::vector<std::string>& lines, int scale, int margin, int width, int height);

 private:
  OverlayGl() = default;
  // Destroyed in reverse order: the program, the texture, the vertex array.
  GlVertexArray vao_;
  GlTexture texture_;
  GlProgram program_;
  std::vector<std::string> lines_;
  int scale_ = 0, tex_width_ = 0, tex_height_ = 0;
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_OVERLAY_GL_H_
