#include "viewer/mode_global_shrm.h"

#include <chrono>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "viewer/gl_util.h"
#include "viewer/glsl_snippets.h"
#include "viewer/reflection_sum.h"

namespace shrm::viewer {
namespace {

constexpr char kFragment[] = R"(#version 330 core
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
uniform samplerCube u_map;
uniform vec3 u_eye;
uniform int u_tangent_index;
out vec4 o_color;
void main() {
  vec3 n = normalize(v_normal);
  vec3 v = normalize(u_eye - v_position);
  vec3 index = u_tangent_index != 0 ? normalize(v_tangent.xyz) : 2.0 * dot(n, v) * n - v;
  o_color = vec4(texture(u_map, index).rgb, 1.0);
}
)";

class GlobalShrmMode final : public RenderMode {
 public:
  [[nodiscard]] absl::Status Init() override {
    SHRM_ASSIGN_OR_RETURN(program_,
                          BuildProgram(kMeshVertexShader, kFragment, "mode 1 (global SHRM)"));
    return absl::OkStatus();
  }

  [[nodiscard]] absl::Status Upload(const SceneData& scene) override {
    sum_.reset();
    if (scene.shrm == nullptr) return absl::OkStatus();
    absl::StatusOr<GlobalReflectionSum> s = GlobalReflectionSum::Create(scene.shrm->global);
    if (!s.ok()) return s.status();
    sum_ = *std::move(s);
    tangent_index_ = scene.shrm->global.index == ReparamKind::kTangent;
    if (!texture_) texture_ = GlTexture::Generate();
    glBindTexture(GL_TEXTURE_CUBE_MAP, texture_.get());
    const int size = sum_->face_size();
    for (int f = 0; f < 6; ++f)
      glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, 0, GL_RGB32F, size, size, 0, GL_RGB,
                   GL_FLOAT, nullptr);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
    return absl::OkStatus();
  }

  bool ready() const override { return program_ && sum_.has_value(); }

  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override {
    if (!ready()) return absl::FailedPreconditionError("mode 1 has no SHRM to draw");
    const auto t0 = std::chrono::steady_clock::now();
    sum_->Compute(frame.central_view, &map_);
    const auto t1 = std::chrono::steady_clock::now();
    sum_ms_ = std::chrono::duration<double, std::milli>(t1 - t0).count();
    const int size = map_.face_size;
    glBindTexture(GL_TEXTURE_CUBE_MAP, texture_.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    for (int f = 0; f < 6; ++f)
      glTexSubImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, 0, 0, 0, size, size, GL_RGB, GL_FLOAT,
                      map_.data.data() + map_.Index(f, 0, 0, 0));
    const GLuint program = program_.get();
    glUseProgram(program);
    SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
    SetUniform(program, "u_eye", static_cast<float>(frame.eye.x), static_cast<float>(frame.eye.y),
               static_cast<float>(frame.eye.z));
    SetUniform(program, "u_tangent_index", tangent_index_ ? 1 : 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_CUBE_MAP, texture_.get());
    SetUniform(program, "u_map", 0);
    frame.mesh->Draw();
    glUseProgram(0);
    return absl::OkStatus();
  }

  std::string Status() const override {
    if (!sum_) return "";
    return absl::StrFormat("per-view map %dx%dx6, P %d, CPU sum %.3f ms", sum_->face_size(),
                           sum_->face_size(), sum_->pmax(), sum_ms_);
  }

 private:
  // Destroyed in reverse order: the texture, then the program.
  GlProgram program_;
  GlTexture texture_;
  std::optional<GlobalReflectionSum> sum_;
  RadianceCube map_;
  bool tangent_index_ = false;
  double sum_ms_ = 0;
};

}  // namespace

std::unique_ptr<RenderMode> MakeGlobalShrmMode() { return std::make_unique<GlobalShrmMode>(); }

}  // namespace shrm::viewer
