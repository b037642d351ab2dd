#include "viewer/mode_irradiance.h"

#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/sh/hbasis.h"
#include "core/sh/sh.h"
#include "viewer/gl_util.h"
#include "viewer/mode_sh_lighting.h"
#include "viewer/scene_source.h"

namespace shrm::viewer {
namespace {

// Degree of the per-vertex lighting: T_h uses bands 0..4 (App. A; A_3 = 0), SH9 bands 0..2.
constexpr int kLightLmax = 4;

constexpr char kVertexMain[] = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_tangent;
layout(location = 3) in vec2 a_uv;
uniform mat4 u_view_projection;
uniform int u_basis;              // 0 H4, 1 H6, 2 SH9
uniform float u_band[LMAX + 1];   // A_l
uniform float u_th[6 * SH_N];     // T_h, row-major (H1..H6 x SH)
out vec3 v_position;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
out vec3 v_coef[9];               // H-basis (4 or 6) or SH9 coefficients of E, RGB
invariant gl_Position;
void main() {
  v_position = a_position;
  v_normal = a_normal;
  v_tangent = a_tangent;
  v_uv = a_uv;
  vec3 c[SH_N];
  LocalLighting(a_normal, a_tangent, c);
  for (int l = 0; l <= LMAX; ++l)
    for (int k = l * l; k < (l + 1) * (l + 1); ++k) c[k] *= u_band[l];
  for (int i = 0; i < 9; ++i) v_coef[i] = vec3(0.0);
  if (u_basis == 2) {
    for (int i = 0; i < 9; ++i) v_coef[i] = c[i];
  } else {
    for (int i = 0; i < 6; ++i) {
      vec3 s = vec3(0.0);
      for (int k = 0; k < SH_N; ++k) s += u_th[i * SH_N + k] * c[k];
      if (i < 4 || u_basis == 1) v_coef[i] = s;
    }
  }
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}
)";

constexpr char kFragmentMain[] = R"(
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in vec3 v_coef[9];
uniform int u_basis;
uniform int u_use_normal_map;
uniform sampler2D u_normal_map;
uniform vec3 u_albedo_over_pi;
out vec4 o_color;
void main() {
  vec3 m = vec3(0.0, 0.0, 1.0);
  if (u_use_normal_map != 0) {
    vec3 t = texture(u_normal_map, v_uv).xyz;
    // A texel without tilt is +z exactly (the flat map renders like no map, bit for bit).
    m = (t.x == 0.0 && t.y == 0.0) ? vec3(0.0, 0.0, 1.0) : normalize(t);
    if (v_tangent.w < 0.0) m.y = -m.y;
  }
  float y[9];
  if (u_basis == 2) {
    // Real SH to degree 2 with the Condon-Shortley phase (docs/conventions.md).
    const float k0 = 0.28209479177387814, k1 = 0.4886025119029199, k2 = 1.0925484305920792;
    const float k20 = 0.31539156525252005, k22 = 0.5462742152960396;
    y[0] = k0;
    y[1] = -k1 * m.y;
    y[2] = k1 * m.z;
    y[3] = -k1 * m.x;
    y[4] = k2 * m.x * m.y;
    y[5] = -k2 * m.y * m.z;
    y[6] = k20 * (3.0 * m.z * m.z - 1.0);
    y[7] = -k2 * m.x * m.z;
    y[8] = k22 * (m.x * m.x - m.y * m.y);
  } else {
    // Eqs. 8-13.
    const float k1 = 0.3989422804014327, k3 = 0.6909882989426661, k15 = 1.5450968080927583;
    y[0] = k1;
    y[1] = -k3 * m.y;
    y[2] = k3 * (2.0 * m.z - 1.0);
    y[3] = -k3 * m.x;
    y[4] = k15 * m.x * m.y;
    y[5] = 0.5 * k15 * (m.x * m.x - m.y * m.y);
    y[6] = 0.0;
    y[7] = 0.0;
    y[8] = 0.0;
  }
  vec3 e = vec3(0.0);
  for (int i = 0; i < 9; ++i) e += v_coef[i] * y[i];
  o_color = vec4(u_albedo_over_pi * e, 1.0);
}
)";

}  // namespace

absl::Status IrradianceMode::Init() {
  program_.reset();
  SHRM_ASSIGN_OR_RETURN(const HBasisConversion th, HBasisConversion::Create(kLightLmax));
  const std::string defines = absl::StrCat("#version 330 core\n#define LMAX ", kLightLmax, "\n");
  SHRM_ASSIGN_OR_RETURN(
      GlProgram program,
      BuildProgram(absl::StrCat(defines, ShRotateZGlsl(kLightLmax), LocalLightingGlsl(kLightLmax),
                                kVertexMain),
                   absl::StrCat("#version 330 core\n", kFragmentMain), "mode 4 (irradiance)"));
  // Constant uniforms (the lighting is set in Upload()): A_l and T_h.
  glUseProgram(program.get());
  std::vector<float> band(kLightLmax + 1);
  for (int l = 0; l <= kLightLmax; ++l) band[l] = static_cast<float>(LambertianBandFactor(l));
  glUniform1fv(glGetUniformLocation(program.get(), "u_band"), kLightLmax + 1, band.data());
  const std::vector<float> t(th.matrix().begin(), th.matrix().end());
  glUniform1fv(glGetUniformLocation(program.get(), "u_th"), static_cast<GLsizei>(t.size()),
               t.data());
  glUseProgram(0);
  program_ = std::move(program);
  return absl::OkStatus();
}

absl::Status IrradianceMode::Upload(const SceneData& scene) {
  env_ = scene.env;
  albedo_ = IrradianceAlbedo(scene.brdf.get());
  if (!program_ || env_ == nullptr || env_->sh.empty()) return absl::OkStatus();
  std::vector<double> world(static_cast<size_t>(ShCount(kLightLmax)) * 3, 0.0);
  std::copy(env_->sh.begin(), env_->sh.begin() + std::min(world.size(), env_->sh.size()),
            world.begin());
  glUseProgram(program_.get());
  SetLocalLightingUniforms(program_.get(), kLightLmax, world.data());
  glUseProgram(0);
  return absl::OkStatus();
}

bool IrradianceMode::ready() const {
  return program_ && env_ != nullptr && env_->sh.size() >= static_cast<size_t>(ShCount(2)) * 3;
}

absl::Status IrradianceMode::Draw(const FrameInputs& frame) {
  if (!ready()) return absl::FailedPreconditionError("mode 4 needs --env");
  const bool use_map = settings_.normal_map != NormalMapKind::kNone;
  if (use_map && settings_.normal_map != normal_uploaded_) {
    const NormalMap map = MakeNormalMap(settings_.normal_map);
    if (!normal_texture_) normal_texture_ = GlTexture::Generate();
    glBindTexture(GL_TEXTURE_2D, normal_texture_.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, map.width, map.height, 0, GL_RGB, GL_FLOAT,
                 map.texels.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    normal_uploaded_ = settings_.normal_map;
  }
  const GLuint program = program_.get();
  glUseProgram(program);
  SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
  SetUniform(program, "u_basis", static_cast<int>(settings_.basis));
  SetUniform(program, "u_use_normal_map", use_map ? 1 : 0);
  SetUniform(program, "u_albedo_over_pi", static_cast<float>(albedo_[0] / kPi),
             static_cast<float>(albedo_[1] / kPi), static_cast<float>(albedo_[2] / kPi));
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, use_map ? normal_texture_.get() : 0);
  SetUniform(program, "u_normal_map", 1);
  glActiveTexture(GL_TEXTURE0);
  frame.mesh->Draw();
  glUseProgram(0);
  return absl::OkStatus();
}

std::string IrradianceMode::Status() const {
  if (!program_) return "";  // unavailable: Init()'s error says why
  return absl::StrFormat(
      "irradiance %s per vertex (lighting l<=%d, exact rotation), albedo %.3g/%.3g/%.3g, normal "
      "map %s [S basis, N normal map]",
      settings_.basis == IrradianceBasis::kH4   ? "H4"
      : settings_.basis == IrradianceBasis::kH6 ? "H6"
                                                : "SH9",
      kLightLmax, albedo_[0], albedo_[1], albedo_[2],
      std::string(NormalMapKindName(settings_.normal_map)));
}

bool IrradianceMode::OnKey(int key, std::string* message) {
  if (key == 'S') {
    settings_.basis = settings_.basis == IrradianceBasis::kH4   ? IrradianceBasis::kH6
                      : settings_.basis == IrradianceBasis::kH6 ? IrradianceBasis::kSh9
                                                                : IrradianceBasis::kH4;
    *message = absl::StrCat("mode 4: irradiance basis ",
                            std::string(IrradianceBasisName(settings_.basis)));
    return true;
  }
  if (key == 'N') {
    settings_.normal_map = NextNormalMapKind(settings_.normal_map);
    *message =
        absl::StrCat("mode 4: normal map ", std::string(NormalMapKindName(settings_.normal_map)));
    return true;
  }
  return false;
}

std::unique_ptr<RenderMode> MakeIrradianceMode() { return std::make_unique<IrradianceMode>(); }

}  // namespace shrm::viewer
