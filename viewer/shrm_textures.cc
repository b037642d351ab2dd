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

}  // namespace shrm::viewer
