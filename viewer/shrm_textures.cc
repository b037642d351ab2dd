#include "viewer/shrm_textures.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "core/export/shrm_ktx2.h"

namespace shrm::viewer {

absl::Status UploadShrmCoefficients(const ShrmCube& cube, GlTexture* texture,
                                    std::vector<float>* layers) {
  const int s = cube.face_size, n = cube.coeff_count();
  GLint max_layers = 0;
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  if (6 * n > max_layers) {
    return absl::ResourceExhaustedError(
        absl::StrCat("6 (P + 1)^2 = ", 6 * n,
                     " coefficient layers exceed GL_MAX_ARRAY_TEXTURE_LAYERS ", max_layers));
  }
  *layers = ShrmCoefficientLayers(cube);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  if (!*texture) *texture = GlTexture::Generate();
  glBindTexture(GL_TEXTURE_2D_ARRAY, texture->get());
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA32F, s, s, 6 * n, 0, GL_RGBA, GL_FLOAT,
               layers->data());
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return absl::OkStatus();
}

void SetShrmFresnel(GLuint program, std::span<const float> fresnel) {
  constexpr int kNodes = kFresnelIntervals + 1;
  if (fresnel.size() < kNodes) {
    glUniform1i(glGetUniformLocation(program, "shrm_fresnel_count"), 0);
    return;
  }
  const int ch = FresnelChannels(fresnel.size());
  std::vector<float> rgb(static_cast<size_t>(kNodes) * 3);
  for (int k = 0; k < kNodes; ++k)
    for (int c = 0; c < 3; ++c)
      rgb[k * 3 + c] = fresnel[static_cast<size_t>(k) * ch + std::min(c, ch - 1)];
  glUniform3fv(glGetUniformLocation(program, "shrm_fresnel"), kNodes, rgb.data());
  glUniform1i(glGetUniformLocation(program, "shrm_fresnel_count"), kNodes);
}

absl::Status UploadShrmLights(std::span<const ShrmLight> lights, GlTexture* texture) {
  if (lights.empty()) return absl::OkStatus();
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  const int k = static_cast<int>(lights.size());
  if (k > max_size) {
    return absl::ResourceExhaustedError(
        absl::StrCat(k, " peak lights exceed GL_MAX_TEXTURE_SIZE ", max_size));
  }
  std::vector<float> texels(static_cast<size_t>(k) * 2 * 4, 0.0f);
  for (int i = 0; i < k; ++i)
    for (int c = 0; c < 3; ++c) {
      texels[static_cast<size_t>(i) * 4 + c] = lights[i].dir[c];
      texels[(static_cast<size_t>(k) + i) * 4 + c] = lights[i].weight[c];
    }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  if (!*texture) *texture = GlTexture::Generate();
  glBindTexture(GL_TEXTURE_2D, texture->get());
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, k, 2, 0, GL_RGBA, GL_FLOAT, texels.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return absl::OkStatus();
}

void SetShrmLights(GLuint program, const GlTexture& texture, int count,
                   const BrdfShaderParams& brdf, int unit) {
  glActiveTexture(GL_TEXTURE0 + unit);
  glBindTexture(GL_TEXTURE_2D, texture.get());
  glActiveTexture(GL_TEXTURE0);
  glUniform1i(glGetUniformLocation(program, "shrm_lights"), unit);
  glUniform1i(glGetUniformLocation(program, "shrm_light_count"), count);
  glUniform1i(glGetUniformLocation(program, "shrm_light_model"), static_cast<int>(brdf.model));
  glUniform4fv(glGetUniformLocation(program, "shrm_light_brdf"), kBrdfShaderValues / 4,
               brdf.values.data());
}

}  // namespace shrm::viewer
