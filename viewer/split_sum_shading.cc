#include "viewer/split_sum_shading.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/brdf/brdf_models.h"
#include "core/ibl/dfg.h"
#include "core/shrm/shrm_eval.h"

namespace shrm::viewer {

namespace {

// The chain's truncation tolerance (relative RMS over the sphere, core/ibl/split_sum.h).
constexpr double kChainTolerance = 1e-3;

const GgxBrdf* AsGgx(const Brdf& brdf) { return dynamic_cast<const GgxBrdf*>(&brdf); }

absl::Status NotGgx(const Brdf& brdf) {
  return absl::InvalidArgumentError(
      absl::StrCat("the split-sum (mode 6) shades GGX only, the BRDF is ", brdf.spec(),
                   ": run with --brdf ggx:alpha=A[,f0=F]"));
}

}  // namespace

ibl::SplitSumSetOptions ViewerSplitSumOptions() {
  ibl::SplitSumSetOptions o;
  o.chain = *ibl::MakeMipChain(ibl::RoughnessPreset::kFilament, kSplitSumFaceSize, 0);
  o.tolerance = kChainTolerance;
  o.irradiance_size = 1;
  return o;
}

absl::StatusOr<SplitSumShading> SplitSumShading::Create(const EnvMap& map, const Brdf& brdf,
                                                        int threads, const Mat3& rotation) {
  if (AsGgx(brdf) == nullptr) return NotGgx(brdf);
  // The light `shrm ibl` and the live session use (the map's peaks split off and summed
  // directly, ibl::ComputeSplitSumLight), so that a fixed map's chain is the live frame's.
  const ibl::SplitSumSetOptions set = ViewerSplitSumOptions();
  absl::StatusOr<ibl::SpecularLight> light = ibl::ComputeSplitSumLight(map, rotation, set, threads);
  if (!light.ok()) return light.status();
  ibl::SpecularOptions opt;
  opt.chain = set.chain;
  opt.tolerance = kChainTolerance;
  opt.threads = threads;
  opt.rotation = rotation;
  absl::StatusOr<ibl::SpecularChain> c = ibl::PrefilterSpecular(map, opt, &*light);
  if (!c.ok()) return c.status();
  return FromChain(*std::move(c), brdf);
}

absl::StatusOr<SplitSumShading> SplitSumShading::FromChain(ibl::SpecularChain chain,
                                                           const Brdf& brdf) {
  const GgxBrdf* ggx = AsGgx(brdf);
  if (ggx == nullptr) return NotGgx(brdf);
  if (chain.levels.empty()) return absl::InvalidArgumentError("split-sum: an empty chain");
  SplitSumShading s;
  s.roughness_ = std::sqrt(ggx->alpha());
  s.f0_ = ggx->f0();
  s.chain_ = std::move(chain);
  // Filament's level for the roughness (light_indirect.fs: lod = (levels - 1) r (2 - r), the
  // inverse of the preset's r = 1 - sqrt(1 - t)).
  const int last = static_cast<int>(s.chain_.levels.size()) - 1;
  s.lod_ = std::clamp(last * s.roughness_ * (2 - s.roughness_), 0.0, static_cast<double>(last));
  const double to_c00 = 2.0 * std::sqrt(kPi);  // B = c00 Y00, Y00 = 1 / (2 sqrt(pi))
  for (const ibl::SpecularLevel& level : s.chain_.levels) {
    ShrmCube cube;
    cube.kind = ShrmKind::kGlobal;
    cube.face_size = level.cube.face_size;
    cube.pmax = 0;
    cube.data.resize(cube.size());
    for (size_t i = 0; i < cube.data.size(); ++i)
      cube.data[i] = static_cast<float>(level.cube.data[i] * to_c00);
    s.levels_.push_back(std::move(cube));
  }
  s.dfg_.resize(2 * kDfgEntries);
  for (int i = 0; i < kDfgEntries; ++i) {
    const ibl::GgxDfg d = ibl::IntegrateGgxDfg((i + 0.5) / kDfgEntries, ggx->alpha());
    s.dfg_[2 * i] = static_cast<float>(d.scale);
    s.dfg_[2 * i + 1] = static_cast<float>(d.bias);
  }
  return s;
}

std::array<double, 3> SplitSumShading::Eval(const Vec3& n, const Vec3& v) const {
  const int k0 = static_cast<int>(std::floor(lod_));
  const int k1 = std::min(k0 + 1, static_cast<int>(levels_.size()) - 1);
  const double t = lod_ - k0;
  const std::array<double, 3> a = ShrmEval(levels_[k0], n, v), b = ShrmEval(levels_[k1], n, v);
  // The table's linear interpolation, clamped at its first and last entries (as GL_CLAMP_TO_EDGE).
  const double x = std::clamp(n.Dot(v), 0.0, 1.0) * kDfgEntries - 0.5;
  const int i0 = std::clamp(static_cast<int>(std::floor(x)), 0, kDfgEntries - 1);
  const int i1 = std::min(i0 + 1, kDfgEntries - 1);
  const double f = std::clamp(x - i0, 0.0, 1.0);
  const double scale = (1 - f) * dfg_[2 * i0] + f * dfg_[2 * i1];
  const double bias = (1 - f) * dfg_[2 * i0 + 1] + f * dfg_[2 * i1 + 1];
  const double e = f0_ * scale + bias;
  std::array<double, 3> out;
  for (int c = 0; c < 3; ++c) out[c] = ((1 - t) * a[c] + t * b[c]) * e;
  return out;
}

}  // namespace shrm::viewer
