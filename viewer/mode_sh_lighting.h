// Mode 3: low-frequency SH lighting with per-pixel BRDF coefficients and normal mapping.
//
// Papers: Krivanek et al. 2006 (rotation paper) sec. 5.1-5.2 (Kautz et al. 2002 with per-pixel
// Taylor rotation for normal maps); Gautron et al. 2004 (HSH paper) sec. 6.1 (HSH BRDF
// coefficients, SH lighting converted by C). The per-pixel mathematics and its CPU twin:
// viewer/sh_lighting_cpu.h. On the GPU:
//  - vertex shader: the world lighting L_lm (degree kShLightingLmax, uniforms) rotated EXACTLY into
//    the vertex's tangent frame (t, n x t, n): zyz angles from the frame's quaternion, then
//    D = Zr(alpha) X^T Zr(beta) X Zr(gamma) with X = D(RotationX(pi/2)) (the zxzxz-rotation of
//    core/sh/rotation.h; X's nonzero entries are literals); the 25 RGB coefficients go to the
//    fragment shader as 19 vec4 outputs and are interpolated;
//  - fragment shader: the frame from the interpolated normal and tangent, the local view, the
//    normal-map normal m (tangent space; y negated for mirrored tangents, w < 0), the perturbed
//    view v_p = Rz(ph) Ry(-th) Rz(-ph) v, the 1.5th-order Taylor rotation of the lighting
//    Zr(ph) Y'(-th) Zr(-ph) (unless "simplified"), h = C L (HSH) and the dot product with the
//    BRDF table (core's OutgoingBrdfTable, a GL_TEXTURE_2D_ARRAY with one layer per coefficient,
//    bilinear, looked up by the parabolic map of v_p).
// Without a normal map (or with the "flat" one) the shading is the unmodified sec. 5.1 algorithm
// (the flat map's rotations are exact identities: the same image, bit for bit).
//
// Keys (while mode 3 is active): S basis SH <-> HSH, N normal map none -> bumps -> steep -> flat,
// T normal mapping Taylor <-> simplified. The table of the current basis is computed in Upload()
// (a new BRDF or environment), the other basis's when it is first drawn (tens to hundreds of ms
// on the GL thread). Errors (render_mode.h): Init() when the default program does not link (too
// few vertex outputs), Upload() / Draw() when the tables refuse the BRDF (Kajiya-Kay) or a shader
// variant does not build.
#ifndef SHRM_VIEWER_MODE_SH_LIGHTING_H_
#define SHRM_VIEWER_MODE_SH_LIGHTING_H_

#include <epoxy/gl.h>

#include <map>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "viewer/gl_util.h"
#include "viewer/normal_map.h"
#include "viewer/render_mode.h"
#include "viewer/sh_lighting_cpu.h"

namespace shrm::viewer {

struct ShLightingSettings {
  HemisphereBasis basis = HemisphereBasis::kSh;
  NormalMapKind normal_map = NormalMapKind::kNone;
  NormalMapping mapping = NormalMapping::kTaylor;  // kTaylor or kSimplified (kExact: CPU only)
};

class ShLightingMode final : public RenderMode {
 public:
  explicit ShLightingMode(const ShLightingSettings& settings = {}) : settings_(settings) {}

  [[nodiscard]] absl::Status Init() override;
  [[nodiscard]] absl::Status Upload(const SceneData& scene) override;
  bool ready() const override;
  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override;
  std::string Status() const override;
  bool OnKey(int key, std::string* message) override;

  const ShLightingSettings& settings() const { return settings_; }
  // Takes effect at the next Draw() (a new basis computes its table then).
  void set_settings(const ShLightingSettings& s) {
    settings_ = s;
    draw_error_ = absl::OkStatus();
  }
  // The CPU twin the GPU draws with (nullptr before the first successful draw of a basis).
  const ShLightingCpu* cpu(HemisphereBasis basis) const;

 private:
  struct Basis {
    std::optional<ShLightingCpu> cpu;
    GlTexture texture;
    bool grey = false;    // one BRDF channel: 4 coefficients per RGBA texel
    absl::Status status;  // the table's error (kept until the BRDF or the environment changes)
  };
  [[nodiscard]] absl::Status PrepareBasis(HemisphereBasis basis);
  void PrepareNormalMap();
  // The program of a shader variant, built on first use (a build error is kept: not retried).
  [[nodiscard]] absl::StatusOr<GLuint> Program(bool normal_map, bool rotate, bool hsh, bool grey);
  [[nodiscard]] absl::Status DrawFrame(const FrameInputs& frame);

  ShLightingSettings settings_;
  std::shared_ptr<const EnvironmentData> env_;
  std::shared_ptr<const Brdf> brdf_;
  std::string brdf_spec_;
  absl::Status init_status_;  // Init(): the default variant's build
  absl::Status draw_error_;   // the last Draw()'s error: not ready() until the settings change
  // Destroyed in reverse order: the tables, the normal map, the programs.
  std::map<int, absl::StatusOr<GlProgram>> programs_;
  GlTexture normal_texture_;
  Basis bases_[2];
  NormalMapKind normal_uploaded_ = NormalMapKind::kNone;
  double table_ms_ = 0;
};

std::unique_ptr<RenderMode> MakeShLightingMode();

// GLSL shared with mode 4, generated for degree lmax (straight-line code with literal
// coefficients: llvmpipe keeps constant-indexed arrays in registers): the real z-rotation of RGB
// coefficients (RotateShZ),
//   const int SH_N = (lmax + 1)^2;
//   void ShRotateZ(float cos_a, float sin_a, inout vec3 c[SH_N]);
// and (after it) the exact rotation of the world lighting (uniform vec3 u_light[SH_N], SH
// frame) into a vertex's tangent frame,
//   void LocalLighting(vec3 normal, vec4 tangent, out vec3 c[SH_N]);
std::string ShRotateZGlsl(int lmax);
std::string LocalLightingGlsl(int lmax);
// Sets LocalLighting's uniform u_light from world RGB coefficients [k * 3 + c] (ShCount(lmax) * 3
// values). The program must be in use.
void SetLocalLightingUniforms(GLuint program, int lmax, const double* world_rgb);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MODE_SH_LIGHTING_H_
