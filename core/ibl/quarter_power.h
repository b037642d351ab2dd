// (e / 4)^x in 16 single-precision lanes, for the Charlie lobe's kernel (sin^2 theta_h = e / 4)
// in the peaks' direct sums (light_peaks.cc) and the pixel sums (split_sum.cc PixelSumTable).
#ifndef SHRM_CORE_IBL_QUARTER_POWER_H_
#define SHRM_CORE_IBL_QUARTER_POWER_H_

#if defined(__AVX512F__)
#include <immintrin.h>

namespace shrm::internal {

// (e / 4)^x for e in [0, 4], x > 0: exp2(x log2(e / 4)) by the AVX-512 exponent and mantissa
// extraction and short series (log2 of the mantissa m in [1, 2) by the atanh series in
// t = (m - 1) / (m + 1) <= 1/3 to t^13, truncation 5e-9; 2^f for |f| <= 1/2 by Taylor to f^7,
// 5e-9), results below 2^-126 flushed to 0. The rounding of x log2(e / 4) in single precision
// dominates: within about 1e-7 |x log2(e / 4)| relative (tests/split_sum_test.cc
// PixelSumTableIsTheReferenceSum, tests/light_peaks_test.cc). libmvec's powf took 6 times as
// long: its lanes that underflow go through a scalar path.
inline __m512 QuarterPower(__m512 e, float x) {
  const __m512 q = _mm512_mul_ps(e, _mm512_set1_ps(0.25f));
  const __m512 k = _mm512_maskz_getexp_ps(0xFFFF, q);
  const __m512 m = _mm512_maskz_getmant_ps(0xFFFF, q, _MM_MANT_NORM_1_2, _MM_MANT_SIGN_zero);
  const __m512 one = _mm512_set1_ps(1.0f);
  const __m512 t = _mm512_div_ps(_mm512_sub_ps(m, one), _mm512_add_ps(m, one));
  const __m512 t2 = _mm512_mul_ps(t, t);
  __m512 series = _mm512_set1_ps(1.0f / 13);
  for (const float c : {1.0f / 11, 1.0f / 9, 1.0f / 7, 1.0f / 5, 1.0f / 3, 1.0f}) {
    series = _mm512_fmadd_ps(series, t2, _mm512_set1_ps(c));
  }
  // log2 q = k + (2 / ln 2) t series.
  const __m512 log2q =
      _mm512_fmadd_ps(_mm512_mul_ps(t, series), _mm512_set1_ps(2.8853900817779268f), k);
  const __m512 y = _mm512_mul_ps(log2q, _mm512_set1_ps(x));
  const __m512 n =
      _mm512_maskz_roundscale_ps(0xFFFF, y, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  const __m512 f = _mm512_mul_ps(_mm512_sub_ps(y, n), _mm512_set1_ps(0.69314718055994531f));
  __m512 p = _mm512_set1_ps(1.0f / 5040);
  for (const float c : {1.0f / 720, 1.0f / 120, 1.0f / 24, 1.0f / 6, 0.5f, 1.0f, 1.0f}) {
    p = _mm512_fmadd_ps(p, f, _mm512_set1_ps(c));
  }
  // (q = 0: getexp gives -inf, y = -inf: flushed with everything below 2^-126.)
  const __mmask16 keep = _mm512_cmp_ps_mask(y, _mm512_set1_ps(-126.0f), _CMP_GT_OQ);
  return _mm512_maskz_scalef_ps(keep, p, n);
}

}  // namespace shrm::internal

#endif  // __AVX512F__
#endif  // SHRM_CORE_IBL_QUARTER_POWER_H_
