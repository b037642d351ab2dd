// Texel decoders written from the specifications, for the container tests (ktx2_test, ktx1_test):
// independent of core/export's encoders and decoders.
#ifndef SHRM_TESTS_FLOAT_DECODERS_H_
#define SHRM_TESTS_FLOAT_DECODERS_H_

#include <Imath/half.h>

#include <array>
#include <cmath>
#include <cstdint>

namespace shrm::testing {

// IEEE half through Imath.
inline float ImathHalfToFloat(uint16_t bits) {
  Imath::half h;
  h.setBits(bits);
  return static_cast<float>(h);
}

// Unsigned 10/11-bit floats: DF spec "Unsigned 11-bit / 10-bit floating-point numbers".
inline double DecodeUfloat(uint32_t n, int mantissa_bits) {
  const uint32_t e = n >> mantissa_bits, m = n & ((1u << mantissa_bits) - 1);
  const double frac = std::ldexp(double(m), -mantissa_bits);
  if (e == 0) return std::ldexp(frac, -14);
  if (e == 31) return m == 0 ? INFINITY : NAN;
  return std::ldexp(1 + frac, int(e) - 15);
}

// B10G11R11 (GL R11F_G11F_B10F, UNSIGNED_INT_10F_11F_11F_REV): R in bits 0..10, G 11..21, B
// 22..31.
inline std::array<double, 3> DecodeB10G11R11(uint32_t w) {
  return {DecodeUfloat(w & 0x7FF, 6), DecodeUfloat((w >> 11) & 0x7FF, 6), DecodeUfloat(w >> 22, 5)};
}

}  // namespace shrm::testing

#endif  // SHRM_TESTS_FLOAT_DECODERS_H_
