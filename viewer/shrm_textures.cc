#include "viewer/shrm_textures.h"

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

}  // namespace shrm::viewer
