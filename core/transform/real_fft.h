// Batched real discrete Fourier transforms of one even width, without FFTW's planner.
//
// The spherical harmonic transforms (core/transform/sht.h) take one real DFT per ring and channel.
// FFTW computes them well, but a process pays for its planner before the first one: about 2 ms to
// register FFTW's solvers on first use, then 0.2-0.5 ms per width to import its wisdom and plan
// (measured in a new process here; docs/results.md "Speed, session 31"), several milliseconds of a
// `shrm ibl` run that transforms at five widths. RealFft needs no planner: a table of twiddle
// factors per width, made once per process in microseconds.
//
// Conventions are FFTW's r2c and c2r (unnormalized):
//   Forward: X_k = sum_{j < W} x_j e^{-2 pi i j k / W}, k = 0 .. W / 2;
//   Inverse: x_j = sum_{k < W} X_k e^{+2 pi i j k / W} with X_{W - k} = conj(X_k), the imaginary
//            parts of X_0 and X_{W/2} ignored (so Inverse(Forward(x)) = W x).
// Both go through one complex DFT of size N = W / 2 (the even and odd samples as real and
// imaginary parts), by Stockham's autosorting algorithm in radix 4, 2, 3, 5 and 7 stages; the
// rows of a batch run in the lanes of a vector (four at a time), so every butterfly is SIMD
// whatever its stride. Widths whose half has another prime factor are not supported (Get returns
// null; the caller keeps FFTW for them).
#ifndef SHRM_CORE_TRANSFORM_REAL_FFT_H_
#define SHRM_CORE_TRANSFORM_REAL_FFT_H_

#include <complex>
#include <memory>
#include <vector>

namespace shrm::internal {

// Batched complex DFTs of one size n whose prime factors are at most 7 (the SHRM grids'
// azimuthal series, core/shrm/shrm_synthesis.cc), by the same stages; FFTW_BACKWARD's convention:
// out_j = sum_k in_k e^{+2 pi i j k / n}, unnormalized.
class ComplexFft {
 public:
  // The transform of size n (cached per process), or null when n < 1 or has a prime factor above
  // 7.
  static std::shared_ptr<const ComplexFft> Get(int n);

  int size() const { return n_; }
  // `series` rows of n values (row r at in + r * n) to rows of n values at out (not in place).
  // Thread-safe (the object is immutable).
  void Backward(const std::complex<double>* in, std::complex<double>* out, int series) const;

 private:
  friend class RealFft;
  explicit ComplexFft(int n);
  struct Stage {
    int radix = 0;
    int length = 0;  // the sub-transform length of this stage (n / product of earlier radices)
    // w^{u p} for p < length / radix, u = 1 .. radix - 1, w = e^{-2 pi i / length}: (re, im)
    // pairs, index (p * (radix - 1) + u - 1).
    std::vector<double> twiddle;
  };
  int n_ = 0;
  std::vector<Stage> stages_;  // in order of application (the forward sign)
};

class RealFft {
 public:
  // The transform of width W (cached per process), or null when W is odd, below 2, or W / 2 has a
  // prime factor above 7.
  static std::shared_ptr<const RealFft> Get(int width);

  int width() const { return 2 * n_; }
  // `rows` rows of W reals in (row r at in + r * W) to W / 2 + 1 complex values each (row r at
  // out + r * (W / 2 + 1)). Thread-safe (the object is immutable).
  void Forward(const double* in, std::complex<double>* out, int rows) const;
  // The inverse, rows of W / 2 + 1 complex values (not modified) to rows of W reals.
  void Inverse(const std::complex<double>* in, double* out, int rows) const;
  // The same with each row where its pointer says (rows of several ring pairs in one batch, so
  // that all four lanes of every vector work).
  void Forward(const double* const* in, std::complex<double>* const* out, int rows) const;
  void Inverse(const std::complex<double>* const* in, double* const* out, int rows) const;

 private:
  explicit RealFft(int n);
  int n_ = 0;                                   // N = W / 2
  std::shared_ptr<const ComplexFft> half_fft_;  // the complex DFT of size N
  std::vector<double> half_;                    // e^{-2 pi i k / W} for k = 0 .. N: (re, im) pairs
};

}  // namespace shrm::internal

#endif  // SHRM_CORE_TRANSFORM_REAL_FFT_H_
