#include "viewer/reflection_sum.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "core/base/parallel.h"
#include "core/sh/sh.h"

namespace shrm::viewer {
namespace {

// Output chunk kept in L1 while the (P + 1)^2 planes stream past it.
constexpr size_t kChunk = 2048;

void SumChunk(const float* __restrict planes, size_t plane_size, const float* __restrict y, int n,
              size_t begin, size_t end, float* __restrict out) {
  for (size_t c0 = begin; c0 < end; c0 += kChunk) {
    const size_t len = std::min(kChunk, end - c0);
    float* __restrict o = out + c0;
    const float* __restrict p0 = planes + c0;
    const float y0 = y[0];
    for (size_t i = 0; i < len; ++i) o[i] = y0 * p0[i];
    for (int k = 1; k < n; ++k) {
      const float* __restrict pk = planes + k * plane_size + c0;
      const float yk = y[k];
      for (size_t i = 0; i < len; ++i) o[i] += yk * pk[i];
    }
  }
}

}  // namespace

absl::StatusOr<GlobalReflectionSum> GlobalReflectionSum::Create(const ShrmCube& cube) {
  if (cube.kind != ShrmKind::kGlobal) {
    return absl::InvalidArgumentError("the per-view reflection map (eq. 5.35) needs a global SHRM");
  }
  if (cube.view != ViewVariable::kView) {
    return absl::InvalidArgumentError(
        "the per-view sum takes Y_pq(V) once per frame: an SHRM in the normal variable "
        "(shrm:view_variable "
        "\"normal\") needs Y_pq per texel (core's ReflectionMapForView, or the GPU pass)");
  }
  if (cube.face_size < 1 || cube.pmax < 0 || cube.channels < 1 || cube.data.size() != cube.size()) {
    return absl::InvalidArgumentError(absl::StrCat("inconsistent SHRM cube (face size ",
                                                   cube.face_size, ", P ", cube.pmax, ", ",
                                                   cube.data.size(), " values)"));
  }
  GlobalReflectionSum s;
  s.face_size_ = cube.face_size;
  s.pmax_ = cube.pmax;
  s.channels_ = cube.channels;
  const int n = cube.coeff_count();
  const size_t texels = static_cast<size_t>(6) * cube.face_size * cube.face_size;
  s.plane_size_ = texels * cube.channels;
  s.planes_.resize(s.plane_size_ * n);
  for (size_t t = 0; t < texels; ++t)
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < cube.channels; ++c)
        s.planes_[k * s.plane_size_ + t * cube.channels + c] =
            cube.data[(t * n + k) * cube.channels + c];
  return s;
}

void GlobalReflectionSum::Compute(const Vec3& view, RadianceCube* out, int threads) const {
  if (out->face_size != face_size_ || out->channels != channels_ ||
      out->data.size() != plane_size_) {
    out->face_size = face_size_;
    out->channels = channels_;
    out->data.assign(plane_size_, 0.0f);
  }
  const int n = ShCount(pmax_);
  float yf[256];
  std::vector<float> ybig;
  float* y = yf;
  if (n > 256) {
    ybig.resize(n);
    y = ybig.data();
  }
  const std::vector<double> yd = EvalSh(pmax_, ShFrameFromWorld(view.Normalized()));
  for (int k = 0; k < n; ++k) y[k] = static_cast<float>(yd[k]);
  const int chunks = static_cast<int>((plane_size_ + kChunk - 1) / kChunk);
  ParallelChunks(chunks, threads, [&](int b, int e) {
    SumChunk(planes_.data(), plane_size_, y, n, static_cast<size_t>(b) * kChunk,
             std::min(plane_size_, static_cast<size_t>(e) * kChunk), out->data.data());
  });
}

}  // namespace shrm::viewer
