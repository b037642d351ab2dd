#include "core/brdf/vector_math.h"

#include <cmath>

#if defined(__AVX512F__) && defined(__x86_64__) && defined(__GLIBC__)
#define SHRM_LIBMVEC 1
#include <immintrin.h>
// libmvec's 8-lane AVX-512 variants (the x86_64 vector function ABI, glibc >= 2.22; asin 2.35).
extern "C" {
__m512d _ZGVeN8v_exp(__m512d);
__m512d _ZGVeN8v_asin(__m512d);
__m512d _ZGVeN8vv_pow(__m512d, __m512d);
__m512d _ZGVeN8v_sin(__m512d);
__m512d _ZGVeN8v_cos(__m512d);
__m512d _ZGVeN8vv_atan2(__m512d, __m512d);
}
#endif

namespace shrm::internal {
namespace {

#if defined(SHRM_LIBMVEC)
// y = f(x) 8 lanes at a time; the last, partial vector is padded with `idle`, a value in every
// function's domain, and stored masked.
template <typename F>
void Lanes(const double* x, double* y, int n, double idle, F f) {
  int i = 0;
  for (; i + 8 <= n; i += 8) _mm512_storeu_pd(y + i, f(_mm512_loadu_pd(x + i)));
  if (i < n) {
    const __mmask8 m = static_cast<__mmask8>((1u << (n - i)) - 1);
    _mm512_mask_storeu_pd(y + i, m, f(_mm512_mask_loadu_pd(_mm512_set1_pd(idle), m, x + i)));
  }
}
#endif

}  // namespace

bool VectorMathUsesLibmvec() {
#if defined(SHRM_LIBMVEC)
  return true;
#else
  return false;
#endif
}

void VectorExp(const double* x, double* y, int n) {
#if defined(SHRM_LIBMVEC)
  Lanes(x, y, n, 0.0, [](__m512d v) { return _ZGVeN8v_exp(v); });
#else
  for (int i = 0; i < n; ++i) y[i] = std::exp(x[i]);
#endif
}

void VectorAsin(const double* x, double* y, int n) {
#if defined(SHRM_LIBMVEC)
  Lanes(x, y, n, 0.0, [](__m512d v) { return _ZGVeN8v_asin(v); });
#else
  for (int i = 0; i < n; ++i) y[i] = std::asin(x[i]);
#endif
}

void VectorPow(const double* x, double e, double* y, int n) {
#if defined(SHRM_LIBMVEC)
  const __m512d ev = _mm512_set1_pd(e);
  Lanes(x, y, n, 1.0, [ev](__m512d v) { return _ZGVeN8vv_pow(v, ev); });
#else
  for (int i = 0; i < n; ++i) y[i] = std::pow(x[i], e);
#endif
}

void VectorSinCos(const double* x, double* s, double* c, int n) {
#if defined(SHRM_LIBMVEC)
  Lanes(x, s, n, 0.0, [](__m512d v) { return _ZGVeN8v_sin(v); });
  Lanes(x, c, n, 0.0, [](__m512d v) { return _ZGVeN8v_cos(v); });
#else
  for (int i = 0; i < n; ++i) ::sincos(x[i], &s[i], &c[i]);
#endif
}

void VectorAtan2(const double* y, const double* x, double* out, int n) {
#if defined(SHRM_LIBMVEC)
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    _mm512_storeu_pd(out + i, _ZGVeN8vv_atan2(_mm512_loadu_pd(y + i), _mm512_loadu_pd(x + i)));
  }
  if (i < n) {
    const __mmask8 m = static_cast<__mmask8>((1u << (n - i)) - 1);
    const __m512d one = _mm512_set1_pd(1.0);
    _mm512_mask_storeu_pd(
        out + i, m,
        _ZGVeN8vv_atan2(_mm512_mask_loadu_pd(one, m, y + i), _mm512_mask_loadu_pd(one, m, x + i)));
  }
#else
  for (int i = 0; i < n; ++i) out[i] = std::atan2(y[i], x[i]);
#endif
}

}  // namespace shrm::internal
