#include "viewer/mode_reference.h"

#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
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
  [[nodiscard]] absl::Status Init() override {
    SHRM_ASSIGN_OR_RETURN(program_,
                          BuildProgram(kMeshVertexShader, kFragment, "mode 5 (reference)"));
    return absl::OkStatus();
  }
  [[nodiscard]] absl::Status Upload(const SceneData& scene) override {
    ready_ = scene.env != nullptr && scene.brdf != nullptr;
    return absl::OkStatus();
  }
  bool ready() const override { return program_ && ready_; }
  bool needs_reference() const override { return true; }
  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override {
    if (!ready()) return absl::FailedPreconditionError("mode 5 needs --env and a BRDF");
    progress_ = frame.reference_progress;
    const GLuint program = program_.get();
    glUseProgram(program);
    SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, frame.reference_texture);
    SetUniform(program, "u_reference", 0);
    SetUniform(program, "u_valid", frame.reference_texture != 0 ? 1 : 0);
    frame.mesh->Draw();
    glUseProgram(0);
    return absl::OkStatus();
  }
  std::string Status() const override {
    return absl::StrFormat("brute force, %.0f%% of the pixels", 100 * progress_);
  }

 private:
  GlProgram program_;
  bool ready_ = false;
  double progress_ = 0;
};

}  // namespace

std::unique_ptr<RenderMode> MakeReferenceMode() { return std::make_unique<ReferenceMode>(); }

}  // namespace shrm::viewer
