#include "core/transform/real_fft.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>

#include "core/base/geometry.h"

namespace shrm::internal {
namespace {

constexpr int kLanes = 4;  // rows of a batch per vector
using V = double __attribute__((vector_size(kLanes * sizeof(double))));

// Split complex vectors: lane l is row l's value.
struct C {
  V re, im;
};
inline C Add(C a, C b) { return {a.re + b.re, a.im + b.im}; }
inline C Sub(C a, C b) { return {a.re - b.re, a.im - b.im}; }
inline C Mul(C a, double wr, double wi) { return {a.re * wr - a.im * wi, a.re * wi + a.im * wr}; }
inline C MinusI(C a) { return {a.im, -a.re}; }  // -i a
inline C PlusI(C a) { return {-a.im, a.re}; }   // +i a

// e^{-2 pi i k / n} as (re, im), from the angle's sine and cosine computed directly (no
// recurrence: every factor within an ulp or two).
void Root(long k, long n, double* re, double* im) {
  const double angle = 2.0 * kPi * static_cast<double>(k) / static_cast<double>(n);
  *re = std::cos(angle);
  *im = -std::sin(angle);
}

// One Stockham stage (forward sign) of radix r, sub-transform length n, stride s, from x to y.
template <int R>
void RadixStage(const C* x, C* y, int n, int s, const double* tw) {
  const int m = n / R;
  for (int p = 0; p < m; ++p) {
    const double* t = tw + static_cast<size_t>(p) * (R - 1) * 2;
    for (int q = 0; q < s; ++q) {
      C a[R];
      for (int j = 0; j < R; ++j) a[j] = x[q + s * (p + j * m)];
      C b[R];
      if constexpr (R == 2) {
        b[0] = Add(a[0], a[1]);
        b[1] = Sub(a[0], a[1]);
      } else if constexpr (R == 8) {
        // Two DFT4 (even and odd members), the odd one turned by omega_8^u.
        constexpr double kR = 0.70710678118654752440;  // 1 / sqrt(2)
        const C e0 = Add(a[0], a[4]), e1 = Sub(a[0], a[4]), e2 = Add(a[2], a[6]),
                e3 = Sub(a[2], a[6]);
        const C o0 = Add(a[1], a[5]), o1 = Sub(a[1], a[5]), o2 = Add(a[3], a[7]),
                o3 = Sub(a[3], a[7]);
        const C even[4] = {Add(e0, e2), Add(e1, MinusI(e3)), Sub(e0, e2), Add(e1, PlusI(e3))};
        C odd[4] = {Add(o0, o2), Add(o1, MinusI(o3)), Sub(o0, o2), Add(o1, PlusI(o3))};
        // omega_8 = (1 - i) / sqrt 2, omega_8^2 = -i, omega_8^3 = -(1 + i) / sqrt 2.
        odd[1] = {kR * (odd[1].re + odd[1].im), kR * (odd[1].im - odd[1].re)};
        odd[2] = MinusI(odd[2]);
        odd[3] = {kR * (odd[3].im - odd[3].re), -kR * (odd[3].re + odd[3].im)};
        for (int u = 0; u < 4; ++u) {
          b[u] = Add(even[u], odd[u]);
          b[u + 4] = Sub(even[u], odd[u]);
        }
      } else if constexpr (R == 4) {
        const C t0 = Add(a[0], a[2]), t1 = Sub(a[0], a[2]), t2 = Add(a[1], a[3]),
                t3 = Sub(a[1], a[3]);
        b[0] = Add(t0, t2);
        b[2] = Sub(t0, t2);
        b[1] = Add(t1, MinusI(t3));
        b[3] = Add(t1, PlusI(t3));
      } else {
        // Odd radix: b_u and b_{r-u} share the sums s_j = a_j + a_{r-j} (cosine parts) and the
        // differences d_j = a_j - a_{r-j} (sine parts), j = 1 .. (r - 1) / 2.
        constexpr int kHalf = R / 2;
        // omega_r^j = e^{-2 pi i j / r} (wr, wi), made once per radix and process.
        static const std::array<std::array<double, R>, 2> kRoots = [] {
          std::array<std::array<double, R>, 2> w{};
          for (int j = 0; j < R; ++j) Root(j, R, &w[0][j], &w[1][j]);
          return w;
        }();
        const std::array<double, R>&wr = kRoots[0], &wi = kRoots[1];
        C sum[kHalf + 1], diff[kHalf + 1];
        b[0] = a[0];
        for (int j = 1; j <= kHalf; ++j) {
          sum[j] = Add(a[j], a[R - j]);
          diff[j] = Sub(a[j], a[R - j]);
          b[0] = Add(b[0], sum[j]);
        }
        for (int u = 1; u <= kHalf; ++u) {
          C c = a[0], e = {V{}, V{}};
          for (int j = 1; j <= kHalf; ++j) {
            const int k = (j * u) % R;  // cos(2 pi k / r) = wr[k], sin(2 pi k / r) = -wi[k]
            c = {c.re + wr[k] * sum[j].re, c.im + wr[k] * sum[j].im};
            e = {e.re - wi[k] * diff[j].re, e.im - wi[k] * diff[j].im};
          }
          b[u] = Add(c, MinusI(e));
          b[R - u] = Add(c, PlusI(e));
        }
      }
      C* out = y + q + static_cast<size_t>(s) * R * p;
      out[0] = b[0];
      for (int u = 1; u < R; ++u)
        out[static_cast<size_t>(s) * u] = Mul(b[u], t[2 * (u - 1)], t[2 * (u - 1) + 1]);
    }
  }
}

// Scratch of one thread: two arrays of N split-complex vectors.
std::vector<C>& Scratch(size_t n) {
  thread_local std::vector<C> buf;
  if (buf.size() < 2 * n) buf.resize(2 * n);
  return buf;
}

// n >= 1 with no prime factor above 7.
bool SevenSmooth(int n) {
  if (n < 1) return false;
  for (int p : {2, 3, 5, 7})
    while (n % p == 0) n /= p;
  return n == 1;
}

}  // namespace

std::shared_ptr<const ComplexFft> ComplexFft::Get(int n) {
  if (!SevenSmooth(n)) return nullptr;
  static std::mutex mu;
  static std::map<int, std::shared_ptr<const ComplexFft>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[n];
  if (!slot) slot = std::shared_ptr<const ComplexFft>(new ComplexFft(n));
  return slot;
}

ComplexFft::ComplexFft(int n) : n_(n) {
  int length = n;
  while (length > 1) {
    int r = 0;
    for (int p : {8, 4, 2, 3, 5, 7}) {
      if (length % p == 0) {
        r = p;
        break;
      }
    }
    Stage st;
    st.radix = r;
    st.length = length;
    const int m = length / r;
    st.twiddle.resize(static_cast<size_t>(m) * (r - 1) * 2);
    for (int p = 0; p < m; ++p)
      for (int u = 1; u < r; ++u) {
        double* t = st.twiddle.data() + (static_cast<size_t>(p) * (r - 1) + u - 1) * 2;
        Root(static_cast<long>(u) * p, length, &t[0], &t[1]);
      }
    stages_.push_back(std::move(st));
    length /= r;
  }
}

std::shared_ptr<const RealFft> RealFft::Get(int width) {
  if (width < 2 || width % 2 != 0 || !SevenSmooth(width / 2)) return nullptr;
  static std::mutex mu;
  static std::map<int, std::shared_ptr<const RealFft>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[width];
  if (!slot) slot = std::shared_ptr<const RealFft>(new RealFft(width / 2));
  return slot;
}

RealFft::RealFft(int n) : n_(n), half_fft_(ComplexFft::Get(n)) {
  half_.resize(static_cast<size_t>(n + 1) * 2);
  for (int k = 0; k <= n; ++k) Root(k, 2L * n, &half_[2 * k], &half_[2 * k + 1]);
}

namespace {

// The complex forward DFT of size n of z (in buf[0, n)) by the stages; returns where it ended
// (buf or buf + n).
template <typename Stages>
C* Transform(const Stages& stages, C* buf, int n) {
  C* x = buf;
  C* y = buf + n;
  int s = 1;
  for (const auto& st : stages) {
    void (*const stage)(const C*, C*, int, int, const double*) = st.radix == 8   ? RadixStage<8>
                                                                 : st.radix == 2 ? RadixStage<2>
                                                                 : st.radix == 3 ? RadixStage<3>
                                                                 : st.radix == 4 ? RadixStage<4>
                                                                 : st.radix == 5 ? RadixStage<5>
                                                                                 : RadixStage<7>;
    stage(x, y, st.length, s, st.twiddle.data());
    s *= st.radix;
    std::swap(x, y);
  }
  return x;
}

// Rows of a lane group: the batch's rows, and for lanes past its end a zero row to read and a
// spare row to write (the same code for whole and partial groups, no per-lane branches).
template <typename T>
T* SpareRow(size_t n) {
  thread_local std::vector<T> spare;
  if (spare.size() < n) spare.assign(n, T{});
  return spare.data();
}

inline V Gather(const double* const* rows, size_t i) {
  return V{rows[0][i], rows[1][i], rows[2][i], rows[3][i]};
}

}  // namespace

void RealFft::Forward(const double* in, std::complex<double>* out, int rows) const {
  std::vector<const double*> in_rows(rows);
  std::vector<std::complex<double>*> out_rows(rows);
  for (int r = 0; r < rows; ++r) {
    in_rows[r] = in + static_cast<size_t>(r) * width();
    out_rows[r] = out + static_cast<size_t>(r) * (n_ + 1);
  }
  Forward(in_rows.data(), out_rows.data(), rows);
}

void RealFft::Inverse(const std::complex<double>* in, double* out, int rows) const {
  std::vector<const std::complex<double>*> in_rows(rows);
  std::vector<double*> out_rows(rows);
  for (int r = 0; r < rows; ++r) {
    in_rows[r] = in + static_cast<size_t>(r) * (n_ + 1);
    out_rows[r] = out + static_cast<size_t>(r) * width();
  }
  Inverse(in_rows.data(), out_rows.data(), rows);
}

void RealFft::Forward(const double* const* in, std::complex<double>* const* out, int rows) const {
  const int n = n_, w = 2 * n, nc = n + 1;
  std::vector<C>& buf = Scratch(static_cast<size_t>(n));
  const double* zero_row = SpareRow<double>(static_cast<size_t>(w));
  std::complex<double>* sink = SpareRow<std::complex<double>>(static_cast<size_t>(nc));
  for (int r0 = 0; r0 < rows; r0 += kLanes) {
    const double* src[kLanes];
    std::complex<double>* dst[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      const bool real_row = r0 + l < rows;
      src[l] = real_row ? in[r0 + l] : zero_row;
      dst[l] = real_row ? out[r0 + l] : sink;
    }
    C* z = buf.data();
    for (int i = 0; i < n; ++i) z[i] = {Gather(src, 2 * i), Gather(src, 2 * i + 1)};
    const C* f = Transform(half_fft_->stages_, buf.data(), n);
    // X_k = E_k + w^k O_k with E_k = (Z_k + conj Z_{N-k}) / 2, O_k = -i (Z_k - conj Z_{N-k}) / 2.
    for (int k = 0; k <= n; ++k) {
      const C a = f[k == n ? 0 : k], bz = f[k == 0 ? 0 : n - k];
      const V er = 0.5 * (a.re + bz.re), ei = 0.5 * (a.im - bz.im);
      const V dr = a.re - bz.re, di = a.im + bz.im;  // Z_k - conj Z_{N-k}
      const C o = {0.5 * di, -0.5 * dr};
      const C x = Add(C{er, ei}, Mul(o, half_[2 * k], half_[2 * k + 1]));
      for (int l = 0; l < kLanes; ++l) dst[l][k] = std::complex<double>(x.re[l], x.im[l]);
    }
  }
}

void RealFft::Inverse(const std::complex<double>* const* in, double* const* out, int rows) const {
  const int n = n_, w = 2 * n, nc = n + 1;
  std::vector<C>& buf = Scratch(static_cast<size_t>(n));
  const std::complex<double>* zero_row = SpareRow<std::complex<double>>(static_cast<size_t>(nc));
  double* sink = SpareRow<double>(static_cast<size_t>(w));
  for (int r0 = 0; r0 < rows; r0 += kLanes) {
    const double* src[kLanes];
    double* dst[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      const bool real_row = r0 + l < rows;
      src[l] = reinterpret_cast<const double*>(real_row ? in[r0 + l] : zero_row);
      dst[l] = real_row ? out[r0 + l] : sink;
    }
    // The imaginary parts of X_0 and X_N are not part of a real signal's spectrum.
    const auto x_at = [&](int k) {
      C v = {Gather(src, 2 * static_cast<size_t>(k)), Gather(src, 2 * static_cast<size_t>(k) + 1)};
      if (k == 0 || k == n) v.im = V{};
      return v;
    };
    // Z_k = (X_k + conj X_{N-k}) + i w^{-k} (X_k - conj X_{N-k}), conjugated here so that the
    // forward stages give the inverse: z = conj(DFT(conj Z)). Pairs k and N - k together.
    C* z = buf.data();
    for (int k = 0; 2 * k <= n; ++k) {
      const int k2 = n - k;
      const C a = x_at(k), b = x_at(k2);
      for (int pass = 0; pass < 2; ++pass) {
        const int kk = pass == 0 ? k : k2;
        if (kk == n || (pass == 1 && k2 == k)) continue;
        const C& p = pass == 0 ? a : b;
        const C& q = pass == 0 ? b : a;              // X_{N-kk}
        const V er = p.re + q.re, ei = p.im - q.im;  // X + conj X'
        const C d = {p.re - q.re, p.im + q.im};      // X - conj X'
        const C o = Mul(d, half_[2 * kk], -half_[2 * kk + 1]);
        z[kk] = {er - o.im, -(ei + o.re)};
      }
    }
    const C* f = Transform(half_fft_->stages_, buf.data(), n);
    for (int i = 0; i < n; ++i)
      for (int l = 0; l < kLanes; ++l) {
        dst[l][2 * i] = f[i].re[l];
        dst[l][2 * i + 1] = -f[i].im[l];
      }
  }
}

void ComplexFft::Backward(const std::complex<double>* in, std::complex<double>* out,
                          int series) const {
  const int n = n_;
  std::vector<C>& buf = Scratch(static_cast<size_t>(n));
  for (int r0 = 0; r0 < series; r0 += kLanes) {
    const int lanes = std::min(kLanes, series - r0);
    const double* src[kLanes];
    for (int l = 0; l < kLanes; ++l)
      src[l] = reinterpret_cast<const double*>(
          in + static_cast<size_t>(r0 + std::min(l, lanes - 1)) * n);
    // The backward DFT is conj(DFT(conj x)): the forward stages on the conjugates.
    C* z = buf.data();
    for (int k = 0; k < n; ++k)
      z[k] = {Gather(src, 2 * static_cast<size_t>(k)),
              -Gather(src, 2 * static_cast<size_t>(k) + 1)};
    const C* f = Transform(stages_, buf.data(), n);
    for (int l = 0; l < lanes; ++l) {
      std::complex<double>* row = out + static_cast<size_t>(r0 + l) * n;
      for (int j = 0; j < n; ++j) row[j] = std::complex<double>(f[j].re[l], -f[j].im[l]);
    }
  }
}

}  // namespace shrm::internal
