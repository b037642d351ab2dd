// Mode 4: irradiance normal mapping with the H-basis (Habel & Wimmer 2010), the SH9 comparison.
//
// The mathematics and its CPU twin: viewer/irradiance_cpu.h. On the GPU:
//  - vertex shader: the world lighting rotated exactly into the vertex's tangent frame
//    (LocalLightingGlsl of viewer/mode_sh_lighting.h, degree 4), E_lm = A_l L_lm, then H4 / H6
//    coefficients h = T_h E (eq. 14 / App. A, T_h as uniforms from core's HBasisConversion) or
//    the SH9 coefficients E_lm, l <= 2; interpolated over the triangle (the paper's per-vertex
//    storage, sec. 5);
//  - fragment shader: E(m) at the normal-map normal m (tangent space, y negated for mirrored
//    tangents), the H-basis polynomials of eqs. 8-13 or the real SH to degree 2 (closed forms);
//    radiance albedo / pi * E (viewer/irradiance_cpu.h: the albedo of a `lambert` BRDF, else 1).
//
// Keys (while mode 4 is active): S basis H4 -> H6 -> SH9, N normal map none -> bumps -> steep ->
// flat.
#ifndef SHRM_VIEWER_MODE_IRRADIANCE_H_
#define SHRM_VIEWER_MODE_IRRADIANCE_H_

#include <epoxy/gl.h>

#include <array>
#include <memory>
#include <string>

#include "viewer/gl_util.h"
#include "viewer/irradiance_cpu.h"
#include "viewer/normal_map.h"
#include "viewer/render_mode.h"

namespace shrm::viewer {

struct IrradianceSettings {
  IrradianceBasis basis = IrradianceBasis::kH6;
  NormalMapKind normal_map = NormalMapKind::kNone;
};

class IrradianceMode final : public RenderMode {
 public:
  explicit IrradianceMode(const IrradianceSettings& settings = {}) : settings_(settings) {}

  // Errors: the program does not build (e.g. too few vertex output components).
  [[nodiscard]] absl::Status Init() override;
  [[nodiscard]] absl::Status Upload(const SceneData& scene) override;
  bool ready() const override;
  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override;
  std::string Status() const override;
  bool OnKey(int key, std::string* message) override;

  const IrradianceSettings& settings() const { return settings_; }
  void set_settings(const IrradianceSettings& s) { settings_ = s; }

 private:
  IrradianceSettings settings_;
  std::shared_ptr<const EnvironmentData> env_;
  std::array<double, 3> albedo_{1, 1, 1};
  // Destroyed in reverse order: the normal map, then the program.
  GlProgram program_;
  GlTexture normal_texture_;
  NormalMapKind normal_uploaded_ = NormalMapKind::kNone;
};

std::unique_ptr<RenderMode> MakeIrradianceMode();

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MODE_IRRADIANCE_H_
