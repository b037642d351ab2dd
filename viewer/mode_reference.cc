#include "viewer/mode_reference.h"

#include "absl/strings/str_format.h"
#include "viewer/gl_util.h"
#include "viewer/glsl_snippets.h"

namespace shrm::viewer {
namespace {

constexpr char kFragment[] = R"(#version 330 core
uniform sampler2D u_reference;
uniform int u_valid;  // 0: no truth of this view yet
out vec4 o_color;
void main() {
  vec4 r = u_valid != 0 ? texelFetch(u_reference, ivec2(gl_FragCoord.xy), 0) : vec4(0.0);
  o_color = vec4(r.a > 0.0 ? r.rgb : vec3(0.02), 1.0);
}
)";

class ReferenceMode final : public RenderMode {
 public:
  ~ReferenceMode() override {
    if (program_ != 0) glDeleteProgram(program_);
  }
  absl::Status Init() override {
    absl::StatusOr<GLuint> p = BuildProgram(kMeshVertexShader, kFragment, "mode 5 (reference)");
    if (!p.ok()) return p.status();
    program_ = *p;
    return absl::OkStatus();
  }
  absl::Status Upload(const SceneData& scene) override {
    ready_ = scene.env != nullptr && scene.brdf != nullptr;
    return absl::OkStatus();
  }
  bool ready() const override { return ready_; }
  bool needs_reference() const override { return true; }
  void Draw(const FrameInputs& frame) override {
    progress_ = frame.reference_progress;
    glUseProgram(program_);
    SetUniformMat4(program_, "u_view_projection", frame.view_projection.data());
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, frame.reference_texture);
    SetUniform(program_, "u_reference", 0);
    SetUniform(program_, "u_valid", frame.reference_texture != 0 ? 1 : 0);
    frame.mesh->Draw();
    glUseProgram(0);
  }
  std::string Status() const override {
    return absl::StrFormat("brute force, %.0f%% of the pixels", 100 * progress_);
  }

 private:
  GLuint program_ = 0;
  bool ready_ = false;
  double progress_ = 0;
};

}  // namespace

std::unique_ptr<RenderMode> MakeReferenceMode() { return std::make_unique<ReferenceMode>(); }

}  // namespace shrm::viewer
