#include "viewer/mode_split_sum.h"

#include <optional>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf_models.h"
#include "viewer/gl_util.h"
#include "viewer/glsl_snippets.h"
#include "viewer/split_sum_shading.h"

namespace shrm::viewer {
namespace {

// The engines' split-sum: the chain at a fixed lod (one roughness per object), the DFG table by
// N.V (column i at N.V = (i + 0.5) / n), F = f0 A + B.
constexpr char kFragment[] = R"(#version 330 core
in vec3 v_position;
in vec3 v_normal;
uniform samplerCube u_chain;
uniform sampler2D u_dfg;
uniform vec3 u_eye;
uniform float u_lod;
uniform float u_f0;
out vec4 o_color;
void main() {
  vec3 n = normalize(v_normal);
  vec3 v = normalize(u_eye - v_position);
  vec3 r = 2.0 * dot(n, v) * n - v;
  vec3 prefiltered = textureLod(u_chain, r, u_lod).rgb;
  vec2 ab = texture(u_dfg, vec2(clamp(dot(n, v), 0.0, 1.0), 0.5)).rg;
  o_color = vec4(prefiltered * (u_f0 * ab.x + ab.y), 1.0);
}
)";

class SplitSumMode final : public RenderMode {
 public:
  [[nodiscard]] absl::Status Init() override {
    SHRM_ASSIGN_OR_RETURN(program_,
                          BuildProgram(kMeshVertexShader, kFragment, "mode 6 (split-sum)"));
    return absl::OkStatus();
  }

  [[nodiscard]] absl::Status Upload(const SceneData& scene) override {
    ready_ = false;
    if (scene.env == nullptr || scene.brdf == nullptr) return absl::OkStatus();
    // The live session's set when there is one (its lighting turned as the frame's), else the
    // chain of the map.
    const void* source = scene.split_sum != nullptr
                             ? static_cast<const void*>(scene.split_sum.get())
                             : scene.env.get();
    if (source == env_ && scene.brdf.get() == brdf_ && shading_) {
      ready_ = true;
      return absl::OkStatus();
    }
    // Not GGX: nothing to draw, and no error (every other BRDF would report one at each scene).
    if (dynamic_cast<const GgxBrdf*>(scene.brdf.get()) == nullptr) return absl::OkStatus();
    absl::StatusOr<SplitSumShading> s =
        scene.split_sum != nullptr
            ? SplitSumShading::FromChain(scene.split_sum->specular, *scene.brdf)
            : SplitSumShading::Create(scene.env->map, *scene.brdf, 2);
    if (!s.ok()) return s.status();
    shading_ = *std::move(s);
    env_ = source;
    brdf_ = scene.brdf.get();
    const ibl::SpecularChain& chain = shading_->chain();
    if (!chain_) chain_ = GlTexture::Generate();
    glBindTexture(GL_TEXTURE_CUBE_MAP, chain_.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    for (size_t k = 0; k < chain.levels.size(); ++k) {
      const RadianceCube& cube = chain.levels[k].cube;
      for (int f = 0; f < 6; ++f)
        glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, static_cast<GLint>(k), GL_RGB32F,
                     cube.face_size, cube.face_size, 0, GL_RGB, GL_FLOAT,
                     cube.data.data() + cube.Index(f, 0, 0, 0));
    }
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_BASE_LEVEL, 0);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAX_LEVEL,
                    static_cast<GLint>(chain.levels.size()) - 1);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
      glTexParameteri(GL_TEXTURE_CUBE_MAP, w, GL_CLAMP_TO_EDGE);
    if (!dfg_) dfg_ = GlTexture::Generate();
    glBindTexture(GL_TEXTURE_2D, dfg_.get());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RG32F, kDfgEntries, 1, 0, GL_RG, GL_FLOAT,
                 shading_->dfg().data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    ready_ = true;
    return absl::OkStatus();
  }

  bool ready() const override { return program_ && ready_; }

  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override {
    if (!ready()) return absl::FailedPreconditionError("mode 6 needs --env and a GGX BRDF");
    const GLuint program = program_.get();
    glUseProgram(program);
    SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
    SetUniform(program, "u_eye", static_cast<float>(frame.eye.x), static_cast<float>(frame.eye.y),
               static_cast<float>(frame.eye.z));
    SetUniform(program, "u_lod", static_cast<float>(shading_->lod()));
    SetUniform(program, "u_f0", static_cast<float>(shading_->f0()));
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_CUBE_MAP, chain_.get());
    SetUniform(program, "u_chain", 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, dfg_.get());
    SetUniform(program, "u_dfg", 1);
    glActiveTexture(GL_TEXTURE0);
    frame.mesh->Draw();
    glUseProgram(0);
    return absl::OkStatus();
  }

  std::string Status() const override {
    if (!ready_) return "";
    return absl::StrFormat(
        "split-sum: GGX chain %d..%d (%d levels, filament), roughness %.3f -> "
        "lod %.2f, f0 %.2f",
        shading_->chain().levels.front().face_size, shading_->chain().levels.back().face_size,
        static_cast<int>(shading_->chain().levels.size()), shading_->roughness(), shading_->lod(),
        shading_->f0());
  }

 private:
  // Destroyed in reverse order: the textures, then the program.
  GlProgram program_;
  GlTexture chain_, dfg_;
  std::optional<SplitSumShading> shading_;
  const void* env_ = nullptr;  // what shading_ was made from (the map's data, or the live set)
  const void* brdf_ = nullptr;
  bool ready_ = false;
};

}  // namespace

std::unique_ptr<RenderMode> MakeSplitSumMode() { return std::make_unique<SplitSumMode>(); }

}  // namespace shrm::viewer
