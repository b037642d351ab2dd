// The analytic BRDF of an SHRM's peak lights as the shipped shaders take it (docs/shaders.md
// "Peak lights"): a model number and 20 numbers, uploaded as `uniform int shrm_light_model` and
// `uniform vec4 shrm_light_brdf[5]` (GLSL) or ShrmLightParams (WGSL), and written to the KTX2
// SHRM as the key "shrm:light_model" ("M v_0 .. v_19"). The shaders evaluate Transfer
// (f_r max(N.w, 0), or the model's own rho-hat) with the arithmetic of core/brdf/brdf_models.cc.
#ifndef SHRM_CORE_BRDF_BRDF_SHADER_PARAMS_H_
#define SHRM_CORE_BRDF_BRDF_SHADER_PARAMS_H_

#include <array>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"

namespace shrm {

// The shaders' model numbers (shaders/glsl/shrm_lights.glsl SHRM_LIGHT_*).
enum class BrdfShaderModel : int {
  kLambert = 1,     // v_0 albedo
  kPhong = 2,       // v_0 s
  kMicrofacet = 3,  // v_0 sigma
  kLafortune = 4,   // v_0 rho_d, v_1 lobe count K <= 4; lobe k: v_{4 + 4k ..} C_xy, C_z, n, rho
  kWard = 5,        // v_0 alpha_x, v_1 alpha_y, v_2 rho_s, v_3 rho_d
  kGgx = 6,         // v_0 alpha, v_1 f0
  kKajiyaKay = 7,   // v_0 s, v_1 the normalization c_s
};

inline constexpr int kBrdfShaderValues = 20;         // vec4[5]
inline constexpr int kBrdfShaderLafortuneLobes = 4;  // vec4 1 .. 4

struct BrdfShaderParams {
  BrdfShaderModel model = BrdfShaderModel::kLambert;
  std::array<float, kBrdfShaderValues> values{};
};

// The parameters of `brdf`; FailedPrecondition for models the shaders do not evaluate (tables,
// MERL, Lafortune with more than 4 lobes), naming the model.
absl::StatusOr<BrdfShaderParams> BrdfShaderParamsFor(const Brdf& brdf);

// The parameters of the BRDF `spec` (shrm:brdf) of an SHRM with `light_count` peak lights:
// InvalidArgument when the spec does not parse, FailedPrecondition when the shaders cannot
// evaluate the model; the messages start with `label` and end with `remedy`.
absl::StatusOr<BrdfShaderParams> PeakLightShaderParams(const std::string& label,
                                                       const std::string& spec, size_t light_count,
                                                       const std::string& remedy);

// "M v_0 .. v_19" (%.9g) and back; Parse rejects unknown models and malformed text.
std::string FormatBrdfShaderParams(const BrdfShaderParams& params);
absl::StatusOr<BrdfShaderParams> ParseBrdfShaderParams(std::string_view text);

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_BRDF_SHADER_PARAMS_H_
