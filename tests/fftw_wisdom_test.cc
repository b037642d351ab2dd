// The FFTW wisdom the build makes for the SH transforms' ring batches
// (core/transform/fftw_wisdom.h): it covers the batches the default jobs plan, each record lets
// FFTW make the plan without its search, that plan is the one FFTW_ESTIMATE makes without the
// record (so the transforms' results do not depend on it), and it computes the discrete Fourier
// transform (a direct sum).
#include "core/transform/fftw_wisdom.h"

#include <fftw3.h>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstring>
#include <random>
#include <vector>

#include "core/shrm/shrm_synthesis.h"

namespace shrm::internal {
namespace {

// The direct sum's rounding grows like sqrt(width) eps of the rings' size; FFTW's like
// log(width) eps. Relative to the largest spectrum value, 1e-12 leaves a margin of ~10x at
// width 8192 (measured at most 4e-14).
constexpr double kDftTolerance = 1e-12;

TEST(FftwWisdomTest, CoversEverySynthesisGridAndTheUsualMapWidths) {
  // Every grid FftFriendlyRings gives from 32 to 2048 rings (the split-sum levels' GridRings and
  // the P = 0 cubes), three channels: two rings per channel.
  int grids = 0;
  for (int rings = FftFriendlyRings(32); rings <= 2048; rings = FftFriendlyRings(rings + 8)) {
    EXPECT_NE(BuiltInWisdom({2 * rings, 6, false}), nullptr) << rings << " rings";
    ++grids;
  }
  EXPECT_GT(grids, 60);
  for (int width : {256, 512, 1024, 2048, 4096, 8192}) {
    EXPECT_NE(BuiltInWisdom({width, 6, true}), nullptr) << "analysis of width " << width;
  }
  // A batch the build made none for.
  EXPECT_EQ(BuiltInWisdom({1000, 6, false}), nullptr);
  EXPECT_EQ(BuiltInWisdom({768, 5, false}), nullptr);
}

// Runs `plan` of `fft` on seeded random input; returns the output (real or interleaved complex).
std::vector<double> Execute(fftw_plan plan, const RingFft& fft, uint64_t seed) {
  const size_t nc = static_cast<size_t>(fft.width) / 2 + 1;
  const size_t real_size = static_cast<size_t>(fft.howmany) * fft.width;
  const size_t complex_size = static_cast<size_t>(fft.howmany) * nc;
  double* re = fftw_alloc_real(real_size);
  fftw_complex* co = fftw_alloc_complex(complex_size);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> out;
  if (fft.forward) {
    for (size_t i = 0; i < real_size; ++i) re[i] = u(rng);
    fftw_execute_dft_r2c(plan, re, co);
    out.assign(reinterpret_cast<double*>(co), reinterpret_cast<double*>(co) + 2 * complex_size);
  } else {
    for (size_t i = 0; i < complex_size; ++i) {
      co[i][0] = u(rng);
      // A real ring's spectrum: the DC (and Nyquist, even width) values are real.
      const size_t k = i % nc;
      co[i][1] = k == 0 || (fft.width % 2 == 0 && k == nc - 1) ? 0.0 : u(rng);
    }
    fftw_execute_dft_c2r(plan, co, re);
    out.assign(re, re + real_size);
  }
  fftw_free(re);
  fftw_free(co);
  return out;
}

// The same input as Execute's, transformed by the direct sum, for ring `ring` only.
std::vector<double> DirectRing(const RingFft& fft, uint64_t seed, int ring) {
  const int n = fft.width, nc = n / 2 + 1;
  std::vector<std::complex<double>> twiddle(n);
  for (int k = 0; k < n; ++k) twiddle[k] = std::polar(1.0, -2 * M_PI * k / n);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> out;
  if (fft.forward) {
    std::vector<double> x(static_cast<size_t>(fft.howmany) * n);
    for (double& v : x) v = u(rng);
    const double* r = x.data() + static_cast<size_t>(ring) * n;
    for (int k = 0; k < nc; ++k) {
      std::complex<double> s = 0;
      for (int j = 0; j < n; ++j) s += r[j] * twiddle[static_cast<size_t>(j) * k % n];
      out.push_back(s.real());
      out.push_back(s.imag());
    }
  } else {
    std::vector<std::complex<double>> x(static_cast<size_t>(fft.howmany) * nc);
    for (size_t i = 0; i < x.size(); ++i) {
      const double a = u(rng);
      const size_t k = i % nc;
      const double b = k == 0 || (n % 2 == 0 && static_cast<int>(k) == nc - 1) ? 0.0 : u(rng);
      x[i] = {a, b};
    }
    const std::complex<double>* c = x.data() + static_cast<size_t>(ring) * nc;
    // FFTW's unnormalized c2r: x_j = sum over the full Hermitian spectrum of X_k e^{+2 pi i jk/n}.
    for (int j = 0; j < n; ++j) {
      double s = c[0].real();
      for (int k = 1; k < nc; ++k) {
        const bool nyquist = n % 2 == 0 && k == nc - 1;
        const std::complex<double> t = c[k] * std::conj(twiddle[static_cast<size_t>(j) * k % n]);
        s += nyquist ? t.real() : 2 * t.real();
      }
      out.push_back(s);
    }
  }
  return out;
}

TEST(FftwWisdomTest, EachRecordMakesTheEstimatePlanWithoutSearchingAndComputesTheDft) {
  for (const RingFft& fft : WisdomRingFfts()) {
    SCOPED_TRACE(testing::Message() << "width " << fft.width << " x " << fft.howmany
                                    << (fft.forward ? " r2c" : " c2r"));
    // The plan without the record, by FFTW_ESTIMATE's search.
    fftw_forget_wisdom();
    fftw_plan searched = PlanRingFft(fft);
    ASSERT_NE(searched, nullptr);
    fftw_forget_wisdom();
    // Without wisdom, FFTW_WISDOM_ONLY makes no plan: the check below means something.
    fftw_plan none = PlanRingFft(fft, /*wisdom_only=*/true);
    EXPECT_EQ(none, nullptr);
    if (none != nullptr) fftw_destroy_plan(none);
    const char* wisdom = BuiltInWisdom(fft);
    ASSERT_NE(wisdom, nullptr);
    ASSERT_EQ(fftw_import_wisdom_from_string(wisdom), 1);
    fftw_plan recorded = PlanRingFft(fft, /*wisdom_only=*/true);
    ASSERT_NE(recorded, nullptr) << "the record does not give the plan";
    const uint64_t seed = static_cast<uint64_t>(fft.width) * 2 + (fft.forward ? 1 : 0);
    const std::vector<double> a = Execute(searched, fft, seed);
    const std::vector<double> b = Execute(recorded, fft, seed);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0)
        << "the recorded plan computes other bits than FFTW_ESTIMATE's";
    // The DFT by the direct sum, for the first and the last ring of the batch (O(width^2)).
    if (fft.width <= 4096) {
      const size_t per_ring = fft.forward ? 2 * (static_cast<size_t>(fft.width) / 2 + 1)
                                          : static_cast<size_t>(fft.width);
      for (int ring : {0, fft.howmany - 1}) {
        const std::vector<double> want = DirectRing(fft, seed, ring);
        double largest = 0, worst = 0;
        for (size_t i = 0; i < per_ring; ++i) {
          largest = std::max(largest, std::abs(want[i]));
          worst = std::max(worst, std::abs(b[ring * per_ring + i] - want[i]));
        }
        EXPECT_LE(worst, kDftTolerance * largest) << "ring " << ring;
      }
    }
    fftw_destroy_plan(searched);
    fftw_destroy_plan(recorded);
  }
  fftw_forget_wisdom();
}

}  // namespace
}  // namespace shrm::internal
