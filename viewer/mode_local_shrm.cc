#include "viewer/mode_local_shrm.h"

#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/sh/sh.h"
#include "shrm/shaders.h"
#include "viewer/gl_util.h"
#include "viewer/glsl_snippets.h"
#include "viewer/shrm_textures.h"

namespace shrm::viewer {
namespace {

// The viewer's two-pass scheme around the shipped evaluators (shaders/glsl/shrm_local.glsl):
// pass 1 (GL >= 4, FAST_PATH) shades the pixels away from the poles with ShrmLocalFiltered,
// pass 2 the others with the exact ShrmLocal.
constexpr char kFragmentMain[] = R"(
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
uniform vec3 u_eye;
uniform int u_tangent_index;
uniform int u_view_normal;  // shrm:view_variable "normal": Y_pq of N = (R + V) / |R + V|, not of V
out vec4 o_color;

#if FAST_PATH
uniform float u_pole_sin;  // the four-tap pass within this sin(alpha) of the poles
#endif

void main() {
  vec3 n = normalize(v_normal);
  vec3 v = normalize(u_eye - v_position);
  vec3 index = u_tangent_index != 0 ? normalize(v_tangent.xyz) : ShrmReflect(n, v);
  vec3 arg = u_view_normal != 0 ? ShrmViewNormal(index, v) : v;
#if FAST_PATH
  // Pass 1, away from the poles the local coefficient field is smooth: filter it in hardware and
  // evaluate once in the frame of the pixel's own index direction.
  if (ShrmPoleDistance(index) <= u_pole_sin) discard;  // left to the four-tap pass
  o_color = vec4(ShrmLocalFiltered(index, arg), 1.0);
#else
  // The four nearest texels, each in its own frame (everywhere, or in pass 2 only the pixels
  // that pass 1 left: the others fail the depth test before shading).
  o_color = vec4(ShrmLocal(index, arg), 1.0);
#endif
#ifdef SHRM_LIGHTS
  // The peak lights at the pixel's own normal (tangent) and view.
  o_color.rgb += ShrmLights(u_tangent_index != 0 ? index : n, v);
#endif
}
)";

// Pixels whose index direction lies within this many texel pitches (2 / S_B at the face centre)
// of the +-Y poles take the exact four-tap path.
constexpr double kPoleTexels = 4;

class LocalShrmMode final : public RenderMode {
 public:
  [[nodiscard]] absl::Status Init() override { return absl::OkStatus(); }

  [[nodiscard]] absl::Status Upload(const SceneData& scene) override {
    ready_ = false;
    if (scene.shrm == nullptr) return absl::OkStatus();
    const ShrmCube& cube = scene.shrm->local;
    const int s = cube.face_size, n = cube.coeff_count();
    GLint major = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    fast_path_ = major >= 4;  // cube map arrays (GL 4.0)
    // shrm:view_variable "normal": SHRM_VIEW_NORMAL (the Fresnel table's argument is N.R).
    const bool view_normal = cube.view == ViewVariable::kNormal;
    const bool lights = !cube.lights.empty();  // SHRM_LIGHTS: shaders/glsl/shrm_lights.glsl
    if (!taps_program_ || pmax_ != cube.pmax || program_view_normal_ != view_normal ||
        program_lights_ != lights) {
      taps_program_.reset();
      filtered_program_.reset();
      pmax_ = -1;
      for (int fast = 0; fast <= (fast_path_ ? 1 : 0); ++fast) {
        const std::string fragment = absl::StrCat(
            fast ? "#version 400 core\n#define SHRM_FILTERED\n" : "#version 330 core\n",
            view_normal ? "#define SHRM_VIEW_NORMAL\n" : "", lights ? "#define SHRM_LIGHTS\n" : "",
            "#define FAST_PATH ", fast, "\n#define PMAX ", cube.pmax, "\n", shaders::kCommonGlsl,
            lights ? shaders::kLightsGlsl : "", shaders::kLocalGlsl, kFragmentMain);
        SHRM_ASSIGN_OR_RETURN((fast ? filtered_program_ : taps_program_),
                              BuildProgram(kMeshVertexShader, fragment,
                                           fast ? "mode 2 (local SHRM, filtered pass)"
                                                : "mode 2 (local SHRM, four-tap pass)"));
      }
      pmax_ = cube.pmax;
      program_view_normal_ = view_normal;
      program_lights_ = lights;
    }
    // Layer k * 6 + face holds coefficient k of that face, texels in GL order: the KTX2 SHRM's
    // level as it is, the layout of a 2D array texture (exact texel fetches) and of a cube-map
    // array (filtered pass) alike.
    std::vector<float> layered;
    SHRM_RETURN_IF_ERROR(UploadShrmCoefficients(cube, &texture_, &layered));
    SHRM_RETURN_IF_ERROR(UploadShrmLights(cube.lights, &lights_texture_));
    light_count_ = static_cast<int>(cube.lights.size());
    light_brdf_ = scene.shrm->light_brdf;
    if (fast_path_) {
      if (!filtered_) filtered_ = GlTexture::Generate();
      glBindTexture(GL_TEXTURE_CUBE_MAP_ARRAY, filtered_.get());
      glTexImage3D(GL_TEXTURE_CUBE_MAP_ARRAY, 0, GL_RGBA32F, s, s, 6 * n, 0, GL_RGBA, GL_FLOAT,
                   layered.data());
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    size_ = s;
    tangent_index_ = cube.index == ReparamKind::kTangent;
    view_normal_ = cube.view == ViewVariable::kNormal;
    fresnel_ = cube.fresnel;
    ready_ = true;
    return absl::OkStatus();
  }

  bool ready() const override { return ready_; }

  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override {
    if (!ready_) return absl::FailedPreconditionError("mode 2 has no SHRM to draw");
    // Pass 1 (GL >= 4): filtered coefficients, one frame per pixel, discarding the pixels near
    // the poles; pass 2: four taps in their own frames, shaded only where pass 1 left no depth
    // (the same vertex shader gives the same depths, so GL_LESS rejects the others early).
    if (fast_path_) Pass(filtered_program_.get(), frame);
    Pass(taps_program_.get(), frame);
    return absl::OkStatus();
  }

  std::string Status() const override {
    if (!ready_) return "";
    return absl::StrFormat(
        "local coefficients %dx%dx6 x %d, per-pixel Y_pq(Rot^T V), %s%s", size_, size_,
        ShCount(pmax_), fast_path_ ? "filtered (4 taps near the poles)" : "4 taps",
        program_lights_ ? absl::StrFormat(" + %d peak lights", light_count_) : "");
  }

 private:
  void Pass(GLuint program, const FrameInputs& frame) {
    glUseProgram(program);
    SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
    SetUniform(program, "u_eye", static_cast<float>(frame.eye.x), static_cast<float>(frame.eye.y),
               static_cast<float>(frame.eye.z));
    SetUniform(program, "shrm_size", size_);
    SetUniform(program, "u_tangent_index", tangent_index_ ? 1 : 0);
    SetUniform(program, "u_view_normal", view_normal_ ? 1 : 0);
    SetShrmFresnel(program, fresnel_);
    if (program_lights_) SetShrmLights(program, lights_texture_, light_count_, light_brdf_, 2);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D_ARRAY, texture_.get());
    SetUniform(program, "shrm_coeffs", 0);
    if (program == filtered_program_.get()) {
      glActiveTexture(GL_TEXTURE1);
      glBindTexture(GL_TEXTURE_CUBE_MAP_ARRAY, filtered_.get());
      SetUniform(program, "shrm_filtered", 1);
      SetUniform(program, "u_pole_sin", static_cast<float>(kPoleTexels * 2.0 / size_));
      glActiveTexture(GL_TEXTURE0);
    }
    frame.mesh->Draw();
    glUseProgram(0);
  }

  // Destroyed in reverse order: the textures, then the programs.
  GlProgram filtered_program_, taps_program_;
  GlTexture filtered_, texture_, lights_texture_;
  std::vector<float> fresnel_;        // the SHRM's Fresnel table (shrm_common.glsl ShrmFresnel)
  bool program_view_normal_ = false;  // the programs were built with SHRM_VIEW_NORMAL
  bool program_lights_ = false;       // ... and with SHRM_LIGHTS
  int light_count_ = 0;
  BrdfShaderParams light_brdf_;
  int pmax_ = -1, size_ = 0;
  bool tangent_index_ = false, view_normal_ = false, ready_ = false, fast_path_ = false;
};

}  // namespace

std::unique_ptr<RenderMode> MakeLocalShrmMode() { return std::make_unique<LocalShrmMode>(); }

}  // namespace shrm::viewer
