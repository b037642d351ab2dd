// Mathematical constants shared by the core folders (kPi is in core/base/geometry.h).
//
// kSqrt2: the factor of the real <-> complex SH conversion (ComplexToReal / RealToComplex in
// core/sh/sh.h, docs/conventions.md) and of the HSH / real Legendre normalizations built on it.
#ifndef SHRM_CORE_BASE_CONSTANTS_H_
#define SHRM_CORE_BASE_CONSTANTS_H_

#include <numbers>

namespace shrm {

inline constexpr double kSqrt2 = std::numbers::sqrt2;

}  // namespace shrm

#endif  // SHRM_CORE_BASE_CONSTANTS_H_
