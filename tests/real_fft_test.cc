// core/transform/real_fft.h (RealFft, ComplexFft) against the defining sums, evaluated term by term
// in long double (an independent reference: no factorization, no twiddle tables).
#include "core/transform/real_fft.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <random>
#include <vector>

namespace shrm::internal {
namespace {

// A DFT's rounding error grows like log2(W) ulps of the input's norm; 1e-14 of the sum of |x_j|
// leaves two orders of magnitude for widths up to 4096 (measured below: under 1e-15).
constexpr double kTol = 1e-14;

// cos and sin of 2 pi t / W, t < W, in long double.
struct Angles {
  explicit Angles(int w) : c(w), s(w) {
    for (int t = 0; t < w; ++t) {
      const long double a = 2.0L * 3.141592653589793238462643383279503L * t / w;
      c[t] = std::cos(a);
      s[t] = std::sin(a);
    }
  }
  std::vector<long double> c, s;
};

std::vector<std::complex<double>> NaiveForward(const double* x, int w, const Angles& t) {
  std::vector<std::complex<double>> out(w / 2 + 1);
  for (int k = 0; k <= w / 2; ++k) {
    long double re = 0, im = 0;
    for (int j = 0; j < w; ++j) {
      const long i = static_cast<long>(j) * k % w;
      re += x[j] * t.c[i];
      im -= x[j] * t.s[i];
    }
    out[k] = {static_cast<double>(re), static_cast<double>(im)};
  }
  return out;
}

// x_j = sum over the Hermitian extension; the imaginary parts of X_0 and X_{W/2} do not enter.
std::vector<double> NaiveInverse(const std::complex<double>* c, int w, const Angles& t) {
  const int n = w / 2;
  std::vector<double> out(w);
  for (int j = 0; j < w; ++j) {
    long double v = c[0].real() + ((j % 2 == 0) ? 1.0L : -1.0L) * c[n].real();
    for (int k = 1; k < n; ++k) {
      const long i = static_cast<long>(j) * k % w;
      v += 2.0L * (c[k].real() * t.c[i] - c[k].imag() * t.s[i]);
    }
    out[j] = static_cast<double>(v);
  }
  return out;
}

TEST(RealFftTest, SupportsEvenWidthsWhoseHalfIsSevenSmooth) {
  for (int w : {2, 4, 6, 8, 10, 14, 48, 96, 210, 1024, 2 * 8 * 3 * 5 * 7})
    EXPECT_NE(RealFft::Get(w), nullptr) << w;
  for (int w : {0, 1, 3, 1023, 22, 26, 2 * 11 * 8, 2 * 13})
    EXPECT_EQ(RealFft::Get(w), nullptr) << w;
  EXPECT_EQ(RealFft::Get(1024), RealFft::Get(1024));  // one per width and process
}

TEST(RealFftTest, ForwardAndInverseAreTheDefiningSums) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0;
  // Radix 4, 2, 3, 5, 7 stages and their mixtures; the SHT's widths (the map's 1024, synthesis
  // grids of 2 x 8 x 7-smooth rings); 1 to 9 rows (whole and partial lane groups).
  for (int w :
       {2, 4, 6, 8, 10, 12, 14, 16, 18, 30, 42, 64, 70, 96, 112, 210, 336, 480, 1024, 1120}) {
    const auto fft = RealFft::Get(w);
    ASSERT_NE(fft, nullptr) << w;
    ASSERT_EQ(fft->width(), w);
    const int nc = w / 2 + 1;
    const Angles angles(w);
    for (int rows : {1, 3, 4, 6, 9}) {
      std::vector<double> x(static_cast<size_t>(rows) * w);
      for (double& v : x) v = u(rng);
      std::vector<std::complex<double>> got(static_cast<size_t>(rows) * nc);
      fft->Forward(x.data(), got.data(), rows);
      std::vector<double> back(x.size());
      // Imaginary parts at 0 and W/2 that a real spectrum would not have: ignored.
      std::vector<std::complex<double>> spectrum = got;
      for (int r = 0; r < rows; ++r) {
        spectrum[static_cast<size_t>(r) * nc] += std::complex<double>(0, 0.25);
        spectrum[static_cast<size_t>(r) * nc + nc - 1] += std::complex<double>(0, -0.5);
      }
      fft->Inverse(spectrum.data(), back.data(), rows);
      for (int r = 0; r < rows; ++r) {
        const double* row = x.data() + static_cast<size_t>(r) * w;
        double norm = 0;
        for (int j = 0; j < w; ++j) norm += std::abs(row[j]);
        const std::vector<std::complex<double>> want = NaiveForward(row, w, angles);
        for (int k = 0; k < nc; ++k) {
          const double e = std::abs(got[static_cast<size_t>(r) * nc + k] - want[k]) / norm;
          worst = std::max(worst, e);
          ASSERT_LE(e, kTol) << "forward W " << w << " rows " << rows << " row " << r << " k " << k;
        }
        const std::vector<double> inv =
            NaiveInverse(spectrum.data() + static_cast<size_t>(r) * nc, w, angles);
        double inv_norm = 0;
        for (int k = 0; k < nc; ++k) inv_norm += 2 * std::abs(want[k]);
        for (int j = 0; j < w; ++j) {
          const double e = std::abs(back[static_cast<size_t>(r) * w + j] - inv[j]) / inv_norm;
          worst = std::max(worst, e);
          ASSERT_LE(e, kTol) << "inverse W " << w << " rows " << rows << " row " << r << " j " << j;
          // Inverse(Forward(x)) = W x.
          ASSERT_NEAR(back[static_cast<size_t>(r) * w + j], w * row[j], kTol * w * norm);
        }
      }
    }
  }
  std::printf("RealFft: largest error %.1e of the input's norm\n", worst);
}

TEST(ComplexFftTest, BackwardIsTheDefiningSum) {
  for (int n : {0, -4, 11, 22, 13 * 8}) EXPECT_EQ(ComplexFft::Get(n), nullptr) << n;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0;
  // The SHRM grids' azimuthal sizes are 2 x 8 x 7-smooth; the small ones cover every radix alone.
  for (int n : {1, 2, 3, 4, 5, 7, 8, 12, 16, 30, 48, 64, 112, 210, 480, 560}) {
    const auto fft = ComplexFft::Get(n);
    ASSERT_NE(fft, nullptr) << n;
    ASSERT_EQ(fft->size(), n);
    const Angles angles(n);
    for (int series : {1, 3, 4, 5, 9}) {
      std::vector<std::complex<double>> x(static_cast<size_t>(series) * n), got(x.size());
      for (auto& v : x) v = {u(rng), u(rng)};
      fft->Backward(x.data(), got.data(), series);
      for (int r = 0; r < series; ++r) {
        const std::complex<double>* row = x.data() + static_cast<size_t>(r) * n;
        double norm = 0;
        for (int k = 0; k < n; ++k) norm += std::abs(row[k]);
        for (int j = 0; j < n; ++j) {
          long double re = 0, im = 0;
          for (int k = 0; k < n; ++k) {
            const long i = static_cast<long>(j) * k % n;
            re += row[k].real() * angles.c[i] - row[k].imag() * angles.s[i];
            im += row[k].real() * angles.s[i] + row[k].imag() * angles.c[i];
          }
          const std::complex<double> want(static_cast<double>(re), static_cast<double>(im));
          const double e = std::abs(got[static_cast<size_t>(r) * n + j] - want) / norm;
          worst = std::max(worst, e);
          ASSERT_LE(e, kTol) << "n " << n << " series " << series << " row " << r << " j " << j;
        }
      }
    }
  }
  std::printf("ComplexFft: largest error %.1e of the input's norm\n", worst);
}

}  // namespace
}  // namespace shrm::internal
