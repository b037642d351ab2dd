// The SHRM's coefficients on the GPU as the shipped shaders bind them (docs/shaders.md): the KTX2
// SHRM's level 0 as it is (core/export/shrm_ktx2.h), a 2D array texture of 6 (P + 1)^2 layers,
// layer 6 k + face = coefficient k, RGBA32F, nearest filtering (texelFetch).
#ifndef SHRM_VIEWER_SHRM_TEXTURES_H_
#define SHRM_VIEWER_SHRM_TEXTURES_H_

#include <span>
#include <vector>

#include "absl/status/status.h"
#include "core/brdf/brdf_shader_params.h"
#include "core/shrm/shrm_map.h"
#include "viewer/gl_util.h"

namespace shrm::viewer {

// Uploads `cube` into *texture (generated on first use) and returns the uploaded layers in
// *layers (for another upload of the same data, e.g. as a cube-map array). ResourceExhausted
// when 6 (P + 1)^2 exceeds GL_MAX_ARRAY_TEXTURE_LAYERS.
[[nodiscard]] absl::Status UploadShrmCoefficients(const ShrmCube& cube, GlTexture* texture,
                                                  std::vector<float>* layers);

// Sets the shaders' Fresnel table (shrm_common.glsl: shrm_fresnel_count, shrm_fresnel) of the
// bound `program` from an SHRM's ShrmCube::fresnel (a 1-channel table in all three components),
// or count 0 for an empty one.
void SetShrmFresnel(GLuint program, std::span<const float> fresnel);

// The SHRM's peak lights as shrm_lights.glsl binds them: a K x 2 RGBA32F texture (texel (k, 0) the
// direction, (k, 1) the weight) in *texture (generated on first use). ResourceExhausted when K
// exceeds GL_MAX_TEXTURE_SIZE. Nothing is uploaded for K = 0.
[[nodiscard]] absl::Status UploadShrmLights(std::span<const ShrmLight> lights, GlTexture* texture);

// Sets shrm_lights.glsl's uniforms of the bound `program`: the lights' texture on texture unit
// `unit` (bound here), their count and the BRDF's model and parameters.
void SetShrmLights(GLuint program, const GlTexture& texture, int count,
                   const BrdfShaderParams& brdf, int unit);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_SHRM_TEXTURES_H_
