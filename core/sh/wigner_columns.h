// Columns of the Wigner small-d matrices, d^l_{mq}(alpha) for all l <= lmax and |m| <= l but only
// |q| <= qmax: what the SHRM synthesis needs (Ramamoorthi & Hanrahan, "Frequency Space
// Environment Map Rendering"), where |q| <= P << F:
//   eq. 5.24: B_mpq(alpha) = sum_l L_lm rho_lpq d^l_mq(alpha) (core/shrm/shrm_synthesis.h);
//   eq. 5.14: B^_ps = sum_q d^p_sq(alpha) B_mpq(alpha) on the grid (qmax = lmax = P).
// The recurrence in l is the Edmonds three-term recurrence of core/sh/wigner.h (Kostelec &
// Rockmore, "FFTs on the rotation group", eq. 4.5),
//   d^{l+1}_{mq} = A_l [(cos alpha - m q / (l (l + 1))) d^l_{mq} - C_l d^{l-1}_{mq}],
// started at l0 = max(|m|, |q|) from the closed form (Wigner's sum has a single term there), e.g.
// d^{l0}_{l0,q}(alpha) = (-1)^{l0-q} sqrt(C(2 l0, l0 + q)) cos^{l0+q}(alpha/2) sin^{l0-q}(alpha/2).
// Conventions (real small-d, Condon-Shortley phase) as in core/sh/wigner.h and docs/conventions.md.
// Cost O(lmax^2 qmax) per angle instead of O(lmax^3) for the full table.
#ifndef SHRM_CORE_SH_WIGNER_COLUMNS_H_
#define SHRM_CORE_SH_WIGNER_COLUMNS_H_

#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

namespace shrm {

// Wigner small-d columns d^l_{mq}(alpha) for |q| <= qmax only (the SHRM needs |q| <= P << F),
// all 0 <= l <= lmax, |m| <= l, by the three-term recurrence in l (core/sh/wigner.h) started from
// the closed form at l = max(|m|, |q|). Cost O(lmax^2 qmax). alpha may be any real number.
// Layout: out[WignerColumnIndex(lmax, qmax, l, m, q)], zero where l < max(|m|, |q|);
// out.size() >= WignerColumnCount(lmax, qmax). Preconditions (assert): 0 <= qmax <= lmax.
constexpr size_t WignerColumnIndex(int lmax, int qmax, int l, int m, int q) {
  return (static_cast<size_t>(q + qmax) * (2 * lmax + 1) + (m + lmax)) * (lmax + 1) + l;
}
constexpr size_t WignerColumnCount(int lmax, int qmax) {
  return static_cast<size_t>(2 * qmax + 1) * (2 * lmax + 1) * (lmax + 1);
}
void WignerColumns(int lmax, int qmax, double alpha, std::span<double> out);
// The same with the recurrence coefficients and start normalizations precomputed (independent of
// alpha); Compute() is const and thread-safe.
class WignerColumnTables {
 public:
  WignerColumnTables(int lmax, int qmax);
  void Compute(double alpha, std::span<double> out) const;
  // Angles per block (Angles, VisitColumn below): the recurrence runs on this many at once.
  static constexpr int kWignerBlock = 8;

  // kWignerBlock doubles, one per angle (a GCC/Clang vector: one AVX-512 register, or split by
  // the compiler on narrower machines).
  using Lanes = double __attribute__((vector_size(kWignerBlock * sizeof(double))));
  // The terms of kWignerBlock angles the recurrences start from (lanes r >= n repeat
  // alpha[n - 1]): cos(alpha), and the powers of cos(alpha / 2) and sin(alpha / 2) of the closed
  // forms (exponents 0 .. 2 lmax).
  struct BlockAngles {
    Lanes x;
    std::vector<Lanes> cpow, spow;
  };
  BlockAngles Angles(const double* alpha, int n) const;
  // The recurrence of one column (m, q) for the block's angles without storing it:
  // visit(l, d) for l = max(|m|, |q|) .. lmax in order, d[r] = d^l_mq(alpha_r) (a Lanes value).
  // A caller that consumes each degree at once (a sum over l) needs no column storage.
  template <class Visit>
  void VisitColumn(const BlockAngles& a, int m, int q, Visit&& visit) const {
    const int l0 = std::max(m < 0 ? -m : m, q < 0 ? -q : q);
    if (l0 > lmax_) return;
    Lanes prev = {}, cur = StartColumn(a, m, q);
    visit(l0, cur);
    const size_t base = WignerColumnIndex(lmax_, qmax_, 0, m, q);
    const double* al = a_.data() + base;
    const double* cl = c_.data() + base;
    const double* sh = shift_.data() + base;
    for (int l = l0; l < lmax_; ++l) {
      const Lanes next = al[l] * ((a.x - sh[l]) * cur - cl[l] * prev);
      prev = cur;
      cur = next;
      visit(l + 1, cur);
    }
  }
  // The columns (m, q) and (-m, q), m > 0, together (they start at the same degree, and their
  // recurrences differ only in the sign of the shift m q / (l (l + 1))): visit(l, d_plus,
  // d_minus) for l = max(m, |q|) .. lmax.
  template <class Visit>
  void VisitColumnPair(const BlockAngles& a, int m, int q, Visit&& visit) const {
    const int l0 = std::max(m, q < 0 ? -q : q);
    if (l0 > lmax_) return;
    Lanes prev_p = {}, prev_m = {}, cur_p = StartColumn(a, m, q), cur_m = StartColumn(a, -m, q);
    visit(l0, cur_p, cur_m);
    const size_t base = WignerColumnIndex(lmax_, qmax_, 0, m, q);
    const double* al = a_.data() + base;
    const double* cl = c_.data() + base;
    const double* sh = shift_.data() + base;
    for (int l = l0; l < lmax_; ++l) {
      const Lanes next_p = al[l] * ((a.x - sh[l]) * cur_p - cl[l] * prev_p);
      const Lanes next_m = al[l] * ((a.x + sh[l]) * cur_m - cl[l] * prev_m);
      prev_p = cur_p;
      prev_m = cur_m;
      cur_p = next_p;
      cur_m = next_m;
      visit(l + 1, cur_p, cur_m);
    }
  }

 private:
  // d^{l0}_mq(alpha_r) at l0 = max(|m|, |q|), the closed form (Wigner's sum has one term there).
  Lanes StartColumn(const BlockAngles& a, int m, int q) const;
  int lmax_, qmax_;
  std::vector<double> a_, c_, shift_;  // per (q, m, l), WignerColumnIndex layout
  std::vector<double> start_;          // sqrt of the binomial of the closed-form start, per (q, m)
};

}  // namespace shrm

#endif  // SHRM_CORE_SH_WIGNER_COLUMNS_H_
