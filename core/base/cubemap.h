// Cube-map geometry in the OpenGL convention (face order +X, -X, +Y, -Y, +Z, -Z and the GL
// specification's major-axis table, sec. 8.13 "Cube Map Texture Selection"), in the world frame
// of docs/conventions.md. Used for cube-map inputs (core/envmap) and SHRM outputs (core/shrm).
//
// For a direction d with major axis face f, the GL table gives (sc, tc, ma) and
//   s = (sc / |ma| + 1) / 2,  t = (tc / |ma| + 1) / 2,
// with texel (x, y) of an S x S face covering s in [x/S, (x+1)/S], t in [y/S, (y+1)/S]; row y = 0
// is the first row stored in the image (t = 0), as glTexImage2D uploads it.
#ifndef SHRM_CORE_BASE_CUBEMAP_H_
#define SHRM_CORE_BASE_CUBEMAP_H_

#include <cmath>

#include "core/base/geometry.h"

namespace shrm {

enum CubeFace : int { kPosX = 0, kNegX = 1, kPosY = 2, kNegY = 3, kPosZ = 4, kNegZ = 5 };
inline constexpr int kCubeFaceCount = 6;
inline constexpr const char* kCubeFaceNames[kCubeFaceCount] = {"px", "nx", "py", "ny", "pz", "nz"};

// Direction (not normalized) of face coordinates s, t in [0, 1]: the inverse of the GL table.
inline Vec3 CubeFaceDirection(int face, double s, double t) {
  const double sc = 2 * s - 1, tc = 2 * t - 1;
  switch (face) {
    case kPosX:
      return {1, -tc, -sc};
    case kNegX:
      return {-1, -tc, sc};
    case kPosY:
      return {sc, 1, tc};
    case kNegY:
      return {sc, -1, -tc};
    case kPosZ:
      return {sc, -tc, 1};
    default:
      return {-sc, -tc, -1};  // kNegZ
  }
}

// Direction of the centre of texel (x, y) of an S x S face, normalized.
inline Vec3 CubeTexelDirection(int face, int x, int y, int size) {
  return CubeFaceDirection(face, (x + 0.5) / size, (y + 0.5) / size).Normalized();
}

// Face and (s, t) in [0, 1] of a nonzero direction, by the GL major-axis table.
inline void CubeFaceCoordinates(const Vec3& d, int* face, double* s, double* t) {
  const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  double sc, tc, ma;
  if (ax >= ay && ax >= az) {
    ma = ax;
    if (d.x > 0) {
      *face = kPosX;
      sc = -d.z;
      tc = -d.y;
    } else {
      *face = kNegX;
      sc = d.z;
      tc = -d.y;
    }
  } else if (ay >= az) {
    ma = ay;
    if (d.y > 0) {
      *face = kPosY;
      sc = d.x;
      tc = d.z;
    } else {
      *face = kNegY;
      sc = d.x;
      tc = -d.z;
    }
  } else {
    ma = az;
    if (d.z > 0) {
      *face = kPosZ;
      sc = d.x;
      tc = -d.y;
    } else {
      *face = kNegZ;
      sc = -d.x;
      tc = -d.y;
    }
  }
  *s = 0.5 * (sc / ma + 1);
  *t = 0.5 * (tc / ma + 1);
}

// Solid angle of texel (x, y) of an S x S face (exact: the area of a rectangle on the unit cube
// projected to the sphere, via the atan formula A(u, v) = atan2(u v, sqrt(u^2 + v^2 + 1))).
inline double CubeTexelSolidAngle(int x, int y, int size) {
  auto area = [](double u, double v) { return std::atan2(u * v, std::sqrt(u * u + v * v + 1)); };
  const double u0 = 2.0 * x / size - 1, u1 = 2.0 * (x + 1) / size - 1;
  const double v0 = 2.0 * y / size - 1, v1 = 2.0 * (y + 1) / size - 1;
  return area(u0, v0) - area(u0, v1) - area(u1, v0) + area(u1, v1);
}

}  // namespace shrm

#endif  // SHRM_CORE_BASE_CUBEMAP_H_
