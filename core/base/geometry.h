// Small fixed-size geometry types used across core: 3-vectors, 3x3 matrices, unit quaternions.
//
// Conventions (docs/conventions.md): right-handed frames, column vectors, active rotations
// (R v rotates the vector v). Matrices are row-major: m[r][c].
#ifndef SHRM_CORE_BASE_GEOMETRY_H_
#define SHRM_CORE_BASE_GEOMETRY_H_

#include <array>
#include <cmath>

namespace shrm {

inline constexpr double kPi = 3.14159265358979323846264338327950288;

struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  constexpr double Dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
  constexpr Vec3 Cross(const Vec3& o) const {
    return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x};
  }
  double Norm() const { return std::sqrt(Dot(*this)); }
  Vec3 Normalized() const { return *this * (1.0 / Norm()); }
};

struct Mat3 {
  std::array<std::array<double, 3>, 3> m{};

  static constexpr Mat3 Identity() { return Mat3{{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}}; }
  constexpr Vec3 operator*(const Vec3& v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  constexpr Mat3 operator*(const Mat3& o) const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        r.m[i][j] = m[i][0] * o.m[0][j] + m[i][1] * o.m[1][j] + m[i][2] * o.m[2][j];
    return r;
  }
  // Exactly the identity (the "no rotation" of option structs, which skip the work then).
  constexpr bool IsIdentity() const {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (m[i][j] != (i == j ? 1.0 : 0.0)) return false;
    return true;
  }
  constexpr Mat3 Transposed() const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.m[i][j] = m[j][i];
    return r;
  }
};

// Active rotation by `angle` radians about the z, y and x axes (right-hand rule).
inline Mat3 RotationZ(double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return Mat3{{{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}}};
}
inline Mat3 RotationY(double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return Mat3{{{{c, 0, s}, {0, 1, 0}, {-s, 0, c}}}};
}
inline Mat3 RotationX(double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return Mat3{{{{1, 0, 0}, {0, c, -s}, {0, s, c}}}};
}

// Unit quaternion w + xi + yj + zk; rotates v by q v q*.
struct Quaternion {
  double w = 1, x = 0, y = 0, z = 0;

  Mat3 ToMatrix() const {
    const double n = std::sqrt(w * w + x * x + y * y + z * z);
    const double a = w / n, b = x / n, c = y / n, d = z / n;
    return Mat3{{{{1 - 2 * (c * c + d * d), 2 * (b * c - a * d), 2 * (b * d + a * c)},
                  {2 * (b * c + a * d), 1 - 2 * (b * b + d * d), 2 * (c * d - a * b)},
                  {2 * (b * d - a * c), 2 * (c * d + a * b), 1 - 2 * (b * b + c * c)}}}};
  }
};

}  // namespace shrm

#endif  // SHRM_CORE_BASE_GEOMETRY_H_
