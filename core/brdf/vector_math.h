// Elementwise exp, asin, pow, sine/cosine and atan2 over arrays of doubles, for the BRDF models'
// evaluation along a quadrature arc (core/brdf/brdf_models.cc), the arc's azimuths
// (core/brdf/brdf_projection.cc) and the angles of cube texels (the split-sum base level, the
// synthesis grids' interpolation taps). Built for AVX-512 (SHRM_NATIVE on such a machine) they call
// glibc's vector math library libmvec, 8 lanes at a time (its documented accuracy: within 4 ulp
// of the exact value); otherwise the scalar libm functions. x and y may be the same array
// (not x and s or c).
#ifndef SHRM_CORE_BRDF_VECTOR_MATH_H_
#define SHRM_CORE_BRDF_VECTOR_MATH_H_

namespace shrm::internal {

// True when the functions below run on libmvec (else libm's scalar functions).
bool VectorMathUsesLibmvec();

void VectorExp(const double* x, double* y, int n);
// x in [-1, 1].
void VectorAsin(const double* x, double* y, int n);
// y[i] = x[i]^e, x[i] >= 0.
void VectorPow(const double* x, double e, double* y, int n);
void VectorSinCos(const double* x, double* s, double* c, int n);
// out[i] = atan2(y[i], x[i]); out may be y or x.
void VectorAtan2(const double* y, const double* x, double* out, int n);

}  // namespace shrm::internal

#endif  // SHRM_CORE_BRDF_VECTOR_MATH_H_
