// Real and complex spherical harmonics of arbitrary degree.
//
// Papers: Ramamoorthi & Hanrahan, "Frequency Space Environment Map Rendering" (complex SH,
// eqs. 5.20-5.24); Gautron et al., "A Novel Hemispherical Basis" eq. 3-4 (the real SH used
// everywhere in shrm). Conventions are fixed in docs/conventions.md:
//  - Angles (theta, phi) are those of the *SH frame* (pole +z_s); for world directions use
//    ShFrameFromWorld() first (x_s = +X, y_s = -Z, z_s = +Y).
//  - Complex SH: Y_lm = K_lm P_l^m(cos theta) e^{i m phi}, orthonormal, with the Condon-Shortley
//    phase (-1)^m inside P_l^m; Y_{l,-m} = (-1)^m conj(Y_lm).
//  - Real SH (HSH paper eq. 3): m > 0: sqrt2 Re Y_lm = sqrt2 K_lm P_l^m cos(m phi);
//    m < 0: sqrt2 Im Y_{l|m|} = sqrt2 K_l|m| P_l^|m| sin(|m| phi); m = 0: Y_l0. The
//    Condon-Shortley phase is kept, so e.g. Y_{1,1} = -sqrt(3/4pi) x, as in the H-basis paper.
//  - Coefficient index i = l (l + 1) + m; a degree-lmax expansion has (lmax + 1)^2 coefficients.
//    (The rotation paper's "order n" is lmax + 1.)
#ifndef SHRM_CORE_SH_SH_H_
#define SHRM_CORE_SH_SH_H_

#include <complex>
#include <span>
#include <vector>

#include "core/base/geometry.h"

namespace shrm {

// Index of (l, m) in a coefficient vector: i = l (l + 1) + m.
constexpr int ShIndex(int l, int m) { return l * (l + 1) + m; }
// Number of coefficients of an expansion up to degree lmax.
constexpr int ShCount(int lmax) { return (lmax + 1) * (lmax + 1); }
// Index of (l, m), 0 <= m <= l, in a triangular table of Legendre values.
constexpr int LegendreIndex(int l, int m) { return l * (l + 1) / 2 + m; }
// Size of a triangular Legendre table up to degree lmax.
constexpr int LegendreCount(int lmax) { return (lmax + 1) * (lmax + 2) / 2; }

// SH frame of a world direction (world: right-handed, +Y up): (x_s, y_s, z_s) = (X, -Z, Y).
constexpr Vec3 ShFrameFromWorld(const Vec3& w) { return {w.x, -w.z, w.y}; }
constexpr Vec3 WorldFromShFrame(const Vec3& s) { return {s.x, s.z, -s.y}; }
// Unit vector of SH angles, and back (phi in (-pi, pi]).
Vec3 DirectionFromAngles(double theta, double phi);
void AnglesFromDirection(const Vec3& d, double* theta, double* phi);

// Fully normalized associated Legendre values lambda_l^m(x) = K_lm P_l^m(x), 0 <= m <= l <= lmax,
// Condon-Shortley phase included, so that Y_lm(theta, phi) = lambda_l^m(cos theta) e^{i m phi}.
// `out` has LegendreCount(lmax) entries, indexed by LegendreIndex(l, m). Stable three-term
// recurrences in l started from the sectoral values (no factorials); pass sin(theta) >= 0
// explicitly so that values near the poles keep full relative precision.
void NormalizedLegendre(int lmax, double cos_theta, double sin_theta, std::span<double> out);
void NormalizedLegendre(int lmax, double cos_theta, std::span<double> out);

// Real SH Y_lm of one direction (SH frame, need not be normalized... but must be nonzero),
// all (lmax + 1)^2 values in ShIndex order.
void EvalSh(int lmax, const Vec3& dir, std::span<double> out);
void EvalSh(int lmax, double theta, double phi, std::span<double> out);
std::vector<double> EvalSh(int lmax, const Vec3& dir);

// Real SH values (times `scale`) from a NormalizedLegendre table and the azimuth's unit vector
// (cos phi, sin phi); cos/sin(m phi) by the multiple-angle recurrence. out[ShIndex(l, m)].
void RealShFromLegendre(int lmax, std::span<const double> lambda, double cos_phi, double sin_phi,
                        double scale, std::span<double> out);

// Vectorized evaluator for many unit directions (SH frame). `out` is direction-minor:
// out[ShIndex(l, m) * dirs.size() + k] = Y_lm(dirs[k]). The recurrences run across directions
// in the innermost loop so the compiler vectorizes them.
void EvalShBatch(int lmax, std::span<const Vec3> dirs, std::span<double> out);

// Textbook twins for tests: explicit Legendre polynomial sums and factorials in long double.
// Accurate only for small degrees (l <= ~20); never used by the library itself.
double EvalShSlow(int l, int m, double theta, double phi);
std::complex<double> EvalComplexShSlow(int l, int m, double theta, double phi);

// Complex SH Y_lm (fast path, via NormalizedLegendre).
std::complex<double> EvalComplexSh(int l, int m, double theta, double phi);
void EvalComplexSh(int lmax, double theta, double phi, std::span<std::complex<double>> out);

// Coefficients of a real function in the two bases (ShIndex order, same lmax):
// r_l0 = c_l0, r_lm = sqrt2 Re c_lm, r_{l,-m} = -sqrt2 Im c_lm (m > 0), and the inverse
// (which fills c_{l,-m} = (-1)^m conj(c_lm)). `complex` must describe a real function for
// ComplexToReal to be lossless.
void ComplexToReal(int lmax, std::span<const std::complex<double>> complex, std::span<double> real);
void RealToComplex(int lmax, std::span<const double> real, std::span<std::complex<double>> complex);

// Evaluates a real SH expansion (ShIndex order) at one direction.
double EvalShSeries(int lmax, std::span<const double> coeffs, const Vec3& dir);

}  // namespace shrm

#endif  // SHRM_CORE_SH_SH_H_
