#include "viewer/normal_map.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace shrm::viewer {

std::string_view NormalMapKindName(NormalMapKind kind) {
  switch (kind) {
    case NormalMapKind::kNone:
      return "none";
    case NormalMapKind::kFlat:
      return "flat";
    case NormalMapKind::kBumps:
      return "bumps";
    case NormalMapKind::kSteepBumps:
      return "steep";
  }
  return "?";
}

absl::StatusOr<NormalMapKind> ParseNormalMapKind(std::string_view name) {
  for (NormalMapKind k : {NormalMapKind::kNone, NormalMapKind::kFlat, NormalMapKind::kBumps,
                          NormalMapKind::kSteepBumps})
    if (name == NormalMapKindName(k)) return k;
  return absl::InvalidArgumentError(absl::StrCat("unknown normal map '", std::string(name),
                                                 "'; valid: none, flat, bumps, steep"));
}

Vec3 NormalMap::Sample(double u, double v) const {
  const double fx = u * width - 0.5, fy = v * height - 0.5;
  const double x0f = std::floor(fx), y0f = std::floor(fy);
  const double ax = fx - x0f, ay = fy - y0f;
  auto wrap = [](long i, int n) { return static_cast<int>(((i % n) + n) % n); };
  const int x0 = wrap(static_cast<long>(x0f), width), x1 = wrap(static_cast<long>(x0f) + 1, width);
  const int y0 = wrap(static_cast<long>(y0f), height);
  const int y1 = wrap(static_cast<long>(y0f) + 1, height);
  auto at = [&](int x, int y) {
    const float* t = &texels[(static_cast<size_t>(y) * width + x) * 3];
    return Vec3{t[0], t[1], t[2]};
  };
  return (at(x0, y0) * (1 - ax) + at(x1, y0) * ax) * (1 - ay) +
         (at(x0, y1) * (1 - ax) + at(x1, y1) * ax) * ay;
}

NormalMap FlatNormalMap(int width, int height) {
  NormalMap m;
  m.width = width;
  m.height = height;
  m.texels.resize(static_cast<size_t>(width) * height * 3, 0.0f);
  for (size_t i = 0; i < m.texels.size(); i += 3) m.texels[i + 2] = 1.0f;
  return m;
}

Vec3 BumpNormal(double u, double v, int periods_u, int periods_v, double max_tilt_deg) {
  const double k = std::tan(max_tilt_deg * kPi / 180);
  const double a = 2 * kPi * periods_u * u, b = 2 * kPi * periods_v * v;
  return Vec3{-k * std::cos(a) * std::sin(b), -k * std::sin(a) * std::cos(b), 1}.Normalized();
}

NormalMap BumpNormalMap(int periods_u, int periods_v, int texels_per_period, double max_tilt_deg) {
  NormalMap m;
  m.width = periods_u * texels_per_period;
  m.height = periods_v * texels_per_period;
  m.texels.resize(static_cast<size_t>(m.width) * m.height * 3);
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      const Vec3 n =
          BumpNormal((x + 0.5) / m.width, (y + 0.5) / m.height, periods_u, periods_v, max_tilt_deg);
      float* t = &m.texels[(static_cast<size_t>(y) * m.width + x) * 3];
      t[0] = static_cast<float>(n.x);
      t[1] = static_cast<float>(n.y);
      t[2] = static_cast<float>(n.z);
    }
  return m;
}

NormalMap MakeNormalMap(NormalMapKind kind) {
  switch (kind) {
    case NormalMapKind::kNone:
      return {};
    case NormalMapKind::kFlat:
      return FlatNormalMap();
    case NormalMapKind::kBumps:
      return BumpNormalMap();
    case NormalMapKind::kSteepBumps:
      return BumpNormalMap(kBumpPeriodsU, kBumpPeriodsV, kBumpTexelsPerPeriod,
                           kSteepBumpMaxTiltDeg);
  }
  return {};
}

NormalMapKind NextNormalMapKind(NormalMapKind kind) {
  switch (kind) {
    case NormalMapKind::kNone:
      return NormalMapKind::kBumps;
    case NormalMapKind::kBumps:
      return NormalMapKind::kSteepBumps;
    case NormalMapKind::kSteepBumps:
      return NormalMapKind::kFlat;
    case NormalMapKind::kFlat:
      return NormalMapKind::kNone;
  }
  return NormalMapKind::kNone;
}

}  // namespace shrm::viewer
