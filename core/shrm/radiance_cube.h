// Plain RGB cube maps produced by the SHRM explicit forms (SHRM paper sec. 5.6.2 end, eq. 5.35)
// and by the angular-domain reference (sec. 5.6.3): one radiance value per texel of the GL cube
// of core/base/cubemap.h, addressed by the reflection vector R (or the normal N for irradiance).
#ifndef SHRM_CORE_SHRM_RADIANCE_CUBE_H_
#define SHRM_CORE_SHRM_RADIANCE_CUBE_H_

#include <cstddef>
#include <vector>

namespace shrm {

struct RadianceCube {
  int face_size = 0;
  int channels = 3;
  std::vector<float> data;  // data[Index(face, x, y, c)]

  size_t Index(int face, int x, int y, int c) const {
    return ((static_cast<size_t>(face) * face_size + y) * face_size + x) * channels + c;
  }
  size_t size() const { return static_cast<size_t>(6) * face_size * face_size * channels; }
};

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_RADIANCE_CUBE_H_
