#include "viewer/mode_global_shrm.h"

#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "shrm/shaders.h"
#include "viewer/gl_util.h"
#include "viewer/glsl_snippets.h"
#include "viewer/shrm_textures.h"

namespace shrm::viewer {
namespace {

// The mesh: this frame's reflection map looked up by R (or T) per pixel.
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

// Restores the framebuffers, viewport, depth test and vertex array the renderer had bound.
class SavedGlState {
 public:
  SavedGlState() {
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &draw_fbo_);
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &read_fbo_);
    glGetIntegerv(GL_VIEWPORT, viewport_);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vao_);
    depth_test_ = glIsEnabled(GL_DEPTH_TEST);
  }
  ~SavedGlState() {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(draw_fbo_));
    glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(read_fbo_));
    glViewport(viewport_[0], viewport_[1], viewport_[2], viewport_[3]);
    glBindVertexArray(static_cast<GLuint>(vao_));
    if (depth_test_) glEnable(GL_DEPTH_TEST);
  }
  SavedGlState(const SavedGlState&) = delete;
  SavedGlState& operator=(const SavedGlState&) = delete;

 private:
  GLint draw_fbo_ = 0, read_fbo_ = 0, viewport_[4] = {}, vao_ = 0;
  GLboolean depth_test_ = GL_FALSE;
};

class GlobalShrmMode final : public RenderMode {
 public:
  [[nodiscard]] absl::Status Init() override {
    SHRM_ASSIGN_OR_RETURN(program_,
                          BuildProgram(kMeshVertexShader, kFragment, "mode 1 (global SHRM)"));
    return absl::OkStatus();
  }

  [[nodiscard]] absl::Status Upload(const SceneData& scene) override {
    ready_ = false;
    if (scene.shrm == nullptr) return absl::OkStatus();
    const ShrmCube& cube = scene.shrm->global;
    if (cube.kind != ShrmKind::kGlobal) {
      return absl::InvalidArgumentError("mode 1 (eq. 5.35) needs a global SHRM");
    }
    const int s = cube.face_size;
    // The per-frame pass of the shipped shader library (shaders/glsl/shrm_global.glsl).
    // shrm:view_variable "normal": the pass takes Y_pq of each texel's normal (SHRM_VIEW_NORMAL).
    const bool view_normal = cube.view == ViewVariable::kNormal;
    // Peak lights: the pass adds them per texel (SHRM_LIGHTS, shaders/glsl/shrm_lights.glsl).
    const bool lights = !cube.lights.empty();
    if (!pass_ || pmax_ != cube.pmax || view_normal_ != view_normal || lights_ != lights) {
      pass_.reset();
      pmax_ = -1;
      const std::string fragment = absl::StrCat(
          "#version 330 core\n#define PMAX ", cube.pmax, "\n#define SHRM_GLOBAL_PASS\n",
          view_normal ? "#define SHRM_VIEW_NORMAL\n" : "", lights ? "#define SHRM_LIGHTS\n" : "",
          shaders::kCommonGlsl, lights ? shaders::kLightsGlsl : "", shaders::kGlobalGlsl);
      SHRM_ASSIGN_OR_RETURN(
          pass_, BuildProgram(absl::StrCat("#version 330 core\n", shaders::kFullscreenVert),
                              fragment, "mode 1 (eq. 5.35 pass, shaders/glsl/shrm_global.glsl)"));
      pmax_ = cube.pmax;
      view_normal_ = view_normal;
      lights_ = lights;
    }
    // The coefficients exactly as the KTX2 SHRM stores them (shaders' binding shrm_coeffs).
    std::vector<float> layers;
    SHRM_RETURN_IF_ERROR(UploadShrmCoefficients(cube, &coeffs_, &layers));
    SHRM_RETURN_IF_ERROR(UploadShrmLights(cube.lights, &lights_texture_));
    light_count_ = static_cast<int>(cube.lights.size());
    light_brdf_ = scene.shrm->light_brdf;
    if (!map_ || size_ != s) {
      map_ = GlTexture::Generate();
      glBindTexture(GL_TEXTURE_CUBE_MAP, map_.get());
      for (int f = 0; f < 6; ++f)
        glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, 0, GL_RGBA32F, s, s, 0, GL_RGBA, GL_FLOAT,
                     nullptr);
      glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
    }
    if (!fbo_) fbo_ = GlFramebuffer::Generate();
    if (!vao_) vao_ = GlVertexArray::Generate();
    {
      SavedGlState saved;
      glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
      glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_CUBE_MAP_POSITIVE_X,
                             map_.get(), 0);
      const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
      if (status != GL_FRAMEBUFFER_COMPLETE) {
        return absl::UnavailableError(absl::StrFormat(
            "mode 1: an RGBA32F cube face is not a complete framebuffer (status 0x%x)", status));
      }
    }
    size_ = s;
    tangent_index_ = cube.index == ReparamKind::kTangent;
    fresnel_ = cube.fresnel;
    ready_ = true;
    return absl::OkStatus();
  }

  bool ready() const override { return program_ && ready_; }

  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override {
    if (!ready()) return absl::FailedPreconditionError("mode 1 has no SHRM to draw");
    {
      // Eq. 5.35 for this frame's central view: six draws, one per face of the map.
      SavedGlState saved;
      glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
      glViewport(0, 0, size_, size_);
      glDisable(GL_DEPTH_TEST);
      glBindVertexArray(vao_.get());
      const GLuint pass = pass_.get();
      glUseProgram(pass);
      SetUniform(pass, "shrm_view", static_cast<float>(frame.central_view.x),
                 static_cast<float>(frame.central_view.y),
                 static_cast<float>(frame.central_view.z));
      glActiveTexture(GL_TEXTURE0);
      glBindTexture(GL_TEXTURE_2D_ARRAY, coeffs_.get());
      SetUniform(pass, "shrm_coeffs", 0);
      SetShrmFresnel(pass, fresnel_);
      if (lights_) SetShrmLights(pass, lights_texture_, light_count_, light_brdf_, 1);
      for (int f = 0; f < 6; ++f) {
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0,
                               GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, map_.get(), 0);
        SetUniform(pass, "shrm_face", f);
        glDrawArrays(GL_TRIANGLES, 0, 3);
      }
      glUseProgram(0);
    }
    const GLuint program = program_.get();
    glUseProgram(program);
    SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
    SetUniform(program, "u_eye", static_cast<float>(frame.eye.x), static_cast<float>(frame.eye.y),
               static_cast<float>(frame.eye.z));
    SetUniform(program, "u_tangent_index", tangent_index_ ? 1 : 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_CUBE_MAP, map_.get());
    SetUniform(program, "u_map", 0);
    frame.mesh->Draw();
    glUseProgram(0);
    return absl::OkStatus();
  }

  std::string Status() const override {
    if (!ready_) return "";
    return absl::StrFormat("per-view map %dx%dx6, P %d, GPU pass (eq. 5.35, shrm_global.glsl)%s",
                           size_, size_, pmax_,
                           lights_ ? absl::StrFormat(" + %d peak lights", light_count_) : "");
  }

 private:
  // Destroyed in reverse order: the GL objects, then the programs.
  GlProgram program_, pass_;
  GlTexture coeffs_, map_, lights_texture_;
  GlFramebuffer fbo_;
  GlVertexArray vao_;
  int pmax_ = -1, size_ = 0;
  bool tangent_index_ = false, view_normal_ = false, lights_ = false, ready_ = false;
  int light_count_ = 0;
  BrdfShaderParams light_brdf_;
  std::vector<float> fresnel_;  // the SHRM's Fresnel table (shrm_common.glsl ShrmFresnel)
};

}  // namespace

std::unique_ptr<RenderMode> MakeGlobalShrmMode() { return std::make_unique<GlobalShrmMode>(); }

}  // namespace shrm::viewer
