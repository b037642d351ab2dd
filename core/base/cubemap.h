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

// Whether m maps each axis onto an axis (a signed permutation matrix: entries 0 or +-1, one
// nonzero per row and column), the frame changes that move cube texels onto cube texels.
inline bool IsSignedPermutation(const Mat3& m) {
  for (int i = 0; i < 3; ++i) {
    int row = 0, col = 0;
    for (int j = 0; j < 3; ++j) {
      if (m.m[i][j] != 0 && std::abs(m.m[i][j]) != 1) return false;
      row += m.m[i][j] != 0;
      col += m.m[j][i] != 0;
    }
    if (row != 1 || col != 1) return false;
  }
  return true;
}

// The cube seen in another frame (n = M d maps world directions d to the frame's n): dst's texel
// at direction n holds src's texel at direction M^T n. For a signed permutation M texel centres
// go onto texel centres, so this is an exact permutation of texels (no resampling). Layout of
// src and dst: faces +X..-Z, S x S texels each, `channels` floats per texel. Returns false (dst
// untouched) if M is not a signed permutation.
inline bool CubeInFrame(const Mat3& m, int size, int channels, const float* src, float* dst) {
  if (!IsSignedPermutation(m)) return false;
  const Mat3 mt = m.Transposed();
  for (int face = 0; face < kCubeFaceCount; ++face)
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        int f = 0;
        double s = 0, t = 0;
        CubeFaceCoordinates(mt * CubeFaceDirection(face, (x + 0.5) / size, (y + 0.5) / size), &f,
                            &s, &t);
        const int sx = static_cast<int>(std::floor(s * size));
        const int sy = static_cast<int>(std::floor(t * size));
        const size_t from = ((static_cast<size_t>(f) * size + sy) * size + sx) * channels;
        const size_t to = ((static_cast<size_t>(face) * size + y) * size + x) * channels;
        for (int c = 0; c < channels; ++c) dst[to + c] = src[from + c];
      }
  return true;
}

}  // namespace shrm

#endif  // SHRM_CORE_BASE_CUBEMAP_H_
