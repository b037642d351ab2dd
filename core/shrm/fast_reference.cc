#include "core/shrm/fast_reference.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/brdf/vector_math.h"

namespace shrm {
namespace {

// Morton bits per face coordinate: 2^-20 of a face (~1e-6 rad), far below any map's texel, so
// only coincident samples share a finest cell.
constexpr int kMortonBits = 20;
// Unit-direction check of Create, as ReferenceIntegrator's.
constexpr double kUnitTolerance = 1e-6;
// Slack of the geometric tests (cap radii are padded by it, horizon tests demand it): covers
// the rounding of the dot products (~1e-16) with room to spare.
constexpr double kGeometrySlack = 1e-12;
// Rec. 709 luminance, only used to weight the node centroids (any positive weights are correct;
// luminance puts the centroid where the light is, which cancels the first-order error).
constexpr std::array<double, 3> kLuminance = {0.2126, 0.7152, 0.0722};
// Lobe scale probe (kReflection): angles from kProbeMinAngle up to pi/2 in steps of sqrt 2; the
// scale is the last angle at which rho-hat is within a factor kProbeFactor of rho-hat(R).
constexpr double kProbeMinAngle = 1e-4;
constexpr double kProbeStep = 1.4142135623730951;
constexpr double kProbeFactor = 2.0;
// Profile of azimuth-independent kTangent models: theta_i on this many cell centres of [0, pi]
// (step 3.1e-3 rad, half a 1024 x 512 map's texel).
constexpr int kProfileSamples = 1024;
// Richardson ratios beyond this mean the children hardly split the node's light (one child holds
// it): |P - Q| cannot see the error inside that child, so such a node is always opened.
constexpr double kMaxRichardson = 100;
// Smallest ratio used (a node whose children are near points still has the error of their
// centres' placement).
constexpr double kMinRichardson = 0.05;
// Eigenvalues of the children's offset matrix below this fraction of the largest are dropped
// (children on a line fix the gradient along the line only).
constexpr double kGradientRankTolerance = 1e-6;
// Above this ratio of its eigenvalues the matrix is inverted directly (the determinant's
// cancellation then costs it at most ~1e-13 relative); below it, eigenvector by eigenvector.
constexpr double kWellConditioned = 1e-3;
// A node N's horizon cuts (AddStraddling): its error bound is this times its light times the
// largest |rho-hat| found on it. Test (b) keeps the node at least four radii from the lobe's
// axis (or within a quarter of its scale), where rho-hat changes across the cap by less than the
// margin between the probed points and the cap's extremes.
constexpr double kStraddleSafety = 2.0;
// A model "jumps" at N's horizon (AddStraddling pays) when rho-hat just above it is at least
// this fraction of its value kJumpProbeHeight (radians) higher; one that falls to zero there
// linearly (a cosine factor: GGX, Lambert) gives about kHorizonNudge / kJumpProbeHeight.
constexpr double kJumpRatio = 0.1;
constexpr double kJumpProbeHeight = 1e-2;
// How far above (and below) the horizon AddStraddling probes rho-hat's value at the cut.
constexpr double kHorizonNudge = 1e-6;

static_assert(sizeof(FastReference::Node) == 96 && sizeof(FastReference::Gradient) == 96);

uint64_t Spread(uint32_t x) {  // bits of x at the even positions
  uint64_t v = x;
  v = (v | (v << 16)) & 0x0000FFFF0000FFFFull;
  v = (v | (v << 8)) & 0x00FF00FF00FF00FFull;
  v = (v | (v << 4)) & 0x0F0F0F0F0F0F0F0Full;
  v = (v | (v << 2)) & 0x3333333333333333ull;
  v = (v | (v << 1)) & 0x5555555555555555ull;
  return v;
}

uint32_t Compact(uint64_t v) {  // the bits of v at the even positions, packed (Spread's inverse)
  v &= 0x5555555555555555ull;
  v = (v | (v >> 1)) & 0x3333333333333333ull;
  v = (v | (v >> 2)) & 0x0F0F0F0F0F0F0F0Full;
  v = (v | (v >> 4)) & 0x00FF00FF00FF00FFull;
  v = (v | (v >> 8)) & 0x0000FFFF0000FFFFull;
  v = (v | (v >> 16)) & 0x00000000FFFFFFFFull;
  return static_cast<uint32_t>(v);
}

// Within an aligned block of 16 tree positions (a 4 x 4 block of pixels), position j's row and
// column offsets: the Morton digit's odd and even bits.
constexpr int BlockRow(int j) { return ((j >> 1) & 1) | ((j >> 2) & 2); }
constexpr int BlockCol(int j) { return (j & 1) | ((j >> 1) & 2); }

uint32_t Quantize(double s) {
  constexpr double kCells = 1 << kMortonBits;
  return static_cast<uint32_t>(std::clamp(s * kCells, 0.0, kCells - 1));
}

// The angle that subtends a chord of the unit sphere, accurate near 0 and pi.
double ChordAngle(double chord) { return 2.0 * std::asin(std::min(1.0, 0.5 * chord)); }

// Angle between unit vectors, accurate near 0 and pi.
double Angle(const Vec3& a, const Vec3& b) { return ChordAngle((a - b).Norm()); }

// Any unit vector perpendicular to the unit vector a.
Vec3 Perpendicular(const Vec3& a) {
  const Vec3 e = std::abs(a.x) < 0.6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return (e - a * a.Dot(e)).Normalized();
}

using Rgb = std::array<double, 3>;

// Sorts (key, index) pairs by key, ties in their given order (the pairs come in index order, so
// the result is std::sort's on the pairs): an LSD radix sort, 16 bits a pass, over the key bits in
// use (43 for a cube's Morton keys: three passes instead of a comparison sort's ~20 levels).
void SortByKey(std::vector<std::pair<uint64_t, int32_t>>& items) {
  constexpr int kDigitBits = 16;
  constexpr size_t kBuckets = size_t{1} << kDigitBits;
  uint64_t all = 0;
  for (const auto& item : items) all |= item.first;
  const int passes = (std::bit_width(all) + kDigitBits - 1) / kDigitBits;
  std::vector<std::pair<uint64_t, int32_t>> other(items.size());
  std::vector<uint32_t> start(kBuckets);
  for (int pass = 0; pass < passes; ++pass) {
    const int shift = pass * kDigitBits;
    std::fill(start.begin(), start.end(), 0u);
    for (const auto& item : items) ++start[(item.first >> shift) & (kBuckets - 1)];
    uint32_t run = 0;
    for (uint32_t& s : start) run += std::exchange(s, run);
    for (const auto& item : items) other[start[(item.first >> shift) & (kBuckets - 1)]++] = item;
    items.swap(other);
  }
}

// The children of the node over samples [begin, end) of the sorted keys: the samples split at
// the first Morton level where their keys differ (single-child chains are collapsed: a node whose
// only child holds the same samples would pass its own check trivially). Writes the groups'
// starts and `end` to bounds[0..groups] and returns groups (2-4), or 0 for a leaf: at most
// kFastReferenceLeafSamples samples, or coincident ones (summed exactly).
int SplitRange(const uint64_t* key, int32_t begin, int32_t end, int32_t bounds[5]) {
  if (end - begin <= kFastReferenceLeafSamples) return 0;
  // Sorted keys: every key of the range shares the bits above the first and last keys' highest
  // differing bit, so the digits at that level rise through the range.
  const uint64_t differ = key[begin] ^ key[end - 1];
  if (differ == 0) return 0;
  const int shift = (std::bit_width(differ) - 1) & ~1;
  int groups = 0;
  for (int32_t k = begin; k < end;) {
    bounds[groups++] = k;
    const uint64_t digit = (key[k] >> shift) & 3;
    k = static_cast<int32_t>(
        std::partition_point(key + k, key + end,
                             [shift, digit](uint64_t x) { return ((x >> shift) & 3) == digit; }) -
        key);
  }
  bounds[groups] = end;
  return groups;
}

// Where a block's sums sit in the arrays of AddWholeBlock and MakeLeafBlock: per channel the
// weight and its first moment (x, y, z), the positive luminance's sum, |w|^2 sum and first moment,
// the plain |w|^2 and w sums, and per channel the |weight| sum.
enum SumSlot {
  kW = 0,
  kF = 3,
  kLum = 12,
  kLumSq = 13,
  kLumDir = 14,
  kSq = 17,
  kPlain = 18,
  kAbs = 21,
  kSums = 24
};

// Eight doubles in vector lanes (one sample per lane) for the leaves' sums.
constexpr int kSumLanes = 8;
using SumLanes = double __attribute__((vector_size(kSumLanes * sizeof(double)), aligned(8)));
SumLanes LoadLanes(const double* p) {
  SumLanes v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}

// Adds a lane's sample (direction x, y, z; weights w per channel) to each sum of `acc` (in
// SumSlot order), for every lane at once.
[[gnu::always_inline]] inline void AccumulateSamples(SumLanes* acc, const SumLanes& x,
                                                     const SumLanes& y, const SumLanes& z,
                                                     const SumLanes* w) {
  const SumLanes sq = x * x + y * y + z * z;
  SumLanes l = kLuminance[0] * w[0] + kLuminance[1] * w[1] + kLuminance[2] * w[2];
  l = l > 0 ? l : 0;
  for (int c = 0; c < 3; ++c) {
    acc[kW + c] += w[c];
    acc[kAbs + c] += w[c] < 0 ? -w[c] : w[c];
    acc[kF + 3 * c] += w[c] * x;
    acc[kF + 3 * c + 1] += w[c] * y;
    acc[kF + 3 * c + 2] += w[c] * z;
  }
  acc[kLum] += l;
  acc[kLumSq] += l * sq;
  acc[kLumDir] += l * x;
  acc[kLumDir + 1] += l * y;
  acc[kLumDir + 2] += l * z;
  acc[kSq] += sq;
  acc[kPlain] += x;
  acc[kPlain + 1] += y;
  acc[kPlain + 2] += z;
}

// A node's sums over its samples, all additive (a parent's are its children's summed):
// per channel the weight L_c dOmega and its first moment sum L_c dOmega w; the positive
// luminance's sums lum_+, lum_+ w and lum_+ |w|^2 (the centroid and the spread about it); and the
// plain sums 1, w, |w|^2 for black nodes.
struct Sums {
  Rgb weight{0, 0, 0};
  Rgb abs_weight{0, 0, 0};  // sum of |L_c dOmega| (the totals' priority weights)
  std::array<Vec3, 3> first{};
  double lum = 0, lum_sq = 0, count = 0, plain_sq = 0;
  Vec3 lum_dir, plain;

  // Adds n <= kFastReferenceLeafSamples samples given as separate coordinates and channel
  // weights (a leaf: the loops run in vector lanes).
  void AddBlock(int n, const double* x, const double* y, const double* z,
                const double* const w[3]) {
    if (n == kFastReferenceLeafSamples) {
      AddWholeBlock(x, y, z, w, n);
      return;
    }
    // A part of a block: padded with zeros (a zero direction and weight add nothing to any sum).
    constexpr int kN = kFastReferenceLeafSamples;
    double px[kN] = {}, py[kN] = {}, pz[kN] = {}, pw[3][kN] = {};
    std::copy_n(x, n, px);
    std::copy_n(y, n, py);
    std::copy_n(z, n, pz);
    for (int c = 0; c < 3; ++c) std::copy_n(w[c], n, pw[c]);
    const double* const padded[3] = {pw[0], pw[1], pw[2]};
    AddWholeBlock(px, py, pz, padded, n);
  }
  // AddBlock of a whole block of kFastReferenceLeafSamples (n of them samples, the rest zeros):
  // each sum in kLanes partial sums (independent, so the loops run in vector lanes without
  // reassociating a sum), added up in a fixed order at the end.
  void AddWholeBlock(const double* x, const double* y, const double* z, const double* const w[3],
                     int n) {
    static_assert(kFastReferenceLeafSamples % kSumLanes == 0);
    SumLanes acc[kSums] = {};
    for (int h = 0; h < kFastReferenceLeafSamples; h += kSumLanes) {
      const SumLanes lw[3] = {LoadLanes(w[0] + h), LoadLanes(w[1] + h), LoadLanes(w[2] + h)};
      AccumulateSamples(acc, LoadLanes(x + h), LoadLanes(y + h), LoadLanes(z + h), lw);
    }
    double total[kSums];
    for (int i = 0; i < kSums; ++i) {
      double t = 0;
      for (int k = 0; k < kSumLanes; ++k) t += acc[i][k];
      total[i] = t;
    }
    AddTotals(total, n);
  }
  // Adds the sums of n samples given in SumSlot order.
  void AddTotals(const double* total, int n) {
    for (int c = 0; c < 3; ++c) {
      weight[c] += total[kW + c];
      abs_weight[c] += total[kAbs + c];
      first[c] = first[c] + Vec3{total[kF + 3 * c], total[kF + 3 * c + 1], total[kF + 3 * c + 2]};
    }
    lum += total[kLum];
    lum_sq += total[kLumSq];
    lum_dir = lum_dir + Vec3{total[kLumDir], total[kLumDir + 1], total[kLumDir + 2]};
    count += n;
    plain_sq += total[kSq];
    plain = plain + Vec3{total[kPlain], total[kPlain + 1], total[kPlain + 2]};
  }
  void Merge(const Sums& o) {
    for (int c = 0; c < 3; ++c) {
      weight[c] += o.weight[c];
      abs_weight[c] += o.abs_weight[c];
      first[c] = first[c] + o.first[c];
    }
    lum += o.lum;
    lum_sq += o.lum_sq;
    lum_dir = lum_dir + o.lum_dir;
    count += o.count;
    plain_sq += o.plain_sq;
    plain = plain + o.plain;
  }
  // Lit: the luminance-weighted mean direction is defined (black nodes, or rounding-degenerate
  // sums, fall back to the plain mean).
  // (In squares: |lum_dir| > 1e-12 |plain|, one square root fewer per test.)
  bool Lit() const { return lum_dir.Dot(lum_dir) > 1e-24 * plain.Dot(plain); }
  Vec3 Centre() const { return Lit() ? lum_dir.Normalized() : plain.Normalized(); }
  // The second moment of the centroid weights about c, sum weight |w - c|^2 (the spread a point
  // rule's r^2 error is proportional to).
  double Spread(const Vec3& c) const {
    const double s = Lit() ? lum_sq - 2 * lum_dir.Dot(c) + lum * c.Dot(c)
                           : plain_sq - 2 * plain.Dot(c) + count * c.Dot(c);
    return std::max(s, 0.0);
  }
  // Channel c's first moment about the centre, sum L_c dOmega (w - centre): the term a gradient
  // of rho-hat multiplies (zero for the luminance that places the centre).
  Vec3 Offset(int c, const Vec3& centre) const { return first[c] - centre * weight[c]; }
};

// The 16 leaves of an aligned 16 x 16 block of a lat-long tree's pixels (tree positions
// [begin, begin + 16 x kFastReferenceLeafSamples)): each leaf's sums, centre and largest squared
// chord from it, made a pixel row of the block at a time with its 16 columns in vector lanes
// (sample by sample, with each leaf's directions and weights gathered from four rows, the
// leaves were about 60% of the build). Leaf j of the block is its Morton digit j: the 4 x 4
// pixels from row 4 BlockRow(j), column 4 BlockCol(j).
// Channel c of a run of 8 RGB pixels held as three 8-lane vectors (value 3k + c is pixel k's):
// lanes whose value lies in run[0] or run[1] (index < 16) from a first shuffle, the rest from
// run[2] (indices 8 .. 15 of the second; -1: a lane not used). __builtin_shufflevector, not GCC's
// __builtin_shuffle, which clang (the fuzz build) lacks.
template <int c, size_t... k>
SumLanes ChannelOfRun(const SumLanes* run, std::index_sequence<k...>) {
  static_assert(sizeof...(k) == 8, "written for 8 lanes");
  const SumLanes first =
      __builtin_shufflevector(run[0], run[1], (3 * int(k) + c < 16 ? 3 * int(k) + c : -1)...);
  return __builtin_shufflevector(first, run[2],
                                 (3 * int(k) + c < 16 ? int(k) : 3 * int(k) + c - 8)...);
}
template <int c>
SumLanes ChannelOfRun(const SumLanes* run) {
  return ChannelOfRun<c>(run, std::make_index_sequence<8>{});
}

constexpr int kBlockSide = 16;  // pixels
constexpr int kBlockLeaves = 16;
static_assert(kFastReferenceLeafSamples * kBlockLeaves == kBlockSide * kBlockSide);
struct LeafBlock {
  std::array<Sums, kBlockLeaves> sums;
  std::array<Vec3, kBlockLeaves> centre;
  std::array<double, kBlockLeaves> chord2;
};
void MakeLeafBlock(const FastReference::SampleStore& store, int32_t begin, LeafBlock* out) {
  // Two leaves' four columns each in the lanes of a vector.
  constexpr int kLanes = kSumLanes, kLeafSide = 4;
  static_assert(kLanes == 8, "the shuffles below are written for 8 lanes");
  using V = SumLanes;
  using F = float __attribute__((vector_size(kLanes * sizeof(float)), aligned(4)));
  int row0, col0;
  store.PixelOf(begin, &row0, &col0);
  for (int g = 0; g < kBlockSide / kLeafSide; ++g) {  // a row of four leaves
    for (int half = 0; half < 2; ++half) {            // two of them
      const int col = col0 + half * kLanes;
      const V cs = LoadLanes(store.col_sin.data() + col),
              cc = LoadLanes(store.col_cos.data() + col);
      V acc[kSums] = {};
      for (int t = 0; t < kLeafSide; ++t) {
        const int row = row0 + kLeafSide * g + t;
        const float* p = store.Pixel(row, col);
        const double omega = store.row_omega[row], rs = store.row_sin[row];
        V run[3];
        for (int q = 0; q < 3; ++q) {
          F f;
          std::memcpy(&f, p + kLanes * q, sizeof(F));
          // L_c dOmega rounded to float, as the exact sums' LeafSamples make it.
          run[q] = __builtin_convertvector(
              __builtin_convertvector(__builtin_convertvector(f, V) * omega, F), V);
        }
        const V w[3] = {ChannelOfRun<0>(run), ChannelOfRun<1>(run), ChannelOfRun<2>(run)};
        AccumulateSamples(acc, rs * cs, V{} + store.row_cos[row], -rs * cc, w);
      }
      // Sums of lanes 0-3 and 4-7 (in lanes 0 and 4), as (a0 + a1) + (a2 + a3).
      for (V& a : acc) {
        a += __builtin_shufflevector(a, a, 1, 0, 3, 2, 5, 4, 7, 6);
        a += __builtin_shufflevector(a, a, 2, 3, 0, 1, 6, 7, 4, 5);
      }
      // The two leaves' sums and centres.
      V cx, cy, cz;
      int leaf_of[2];
      for (int k = 0; k < 2; ++k) {
        const int h = 2 * half + k, lane = kLeafSide * k;
        const int j = (h & 1) | ((g & 1) << 1) | ((h & 2) << 1) | ((g & 2) << 2);
        leaf_of[k] = j;
        double total[kSums];
        for (int i = 0; i < kSums; ++i) total[i] = acc[i][lane];
        Sums& sums = out->sums[j];
        sums = Sums{};
        sums.AddTotals(total, kFastReferenceLeafSamples);
        const Vec3 centre = sums.Centre();
        out->centre[j] = centre;
        for (int i = lane; i < lane + kLeafSide; ++i) {
          cx[i] = centre.x;
          cy[i] = centre.y;
          cz[i] = centre.z;
        }
      }
      // Each leaf's largest squared chord from its centre.
      V chord2 = {};
      for (int t = 0; t < kLeafSide; ++t) {
        const int row = row0 + kLeafSide * g + t;
        const double rs = store.row_sin[row];
        const V dx = rs * cs - cx, dy = store.row_cos[row] - cy, dz = -rs * cc - cz;
        const V d2 = dx * dx + dy * dy + dz * dz;
        chord2 = chord2 > d2 ? chord2 : d2;
      }
      for (int k = 0; k < 2; ++k) {
        double m = 0;
        for (int i = kLeafSide * k; i < kLeafSide * (k + 1); ++i) m = std::max(m, chord2[i]);
        out->chord2[leaf_of[k]] = m;
      }
    }
  }
}

// The Richardson ratio and the first-order correction of internal node i (Create), from its sums
// and its children's.
void SetGradient(std::vector<FastReference::Node>& nodes,
                 std::vector<FastReference::Gradient>& gradients, int32_t i, const Sums& sums,
                 std::span<const Sums> child) {
  FastReference::Node& node = nodes[i];
  const Vec3 c = node.centre;
  {
    // Richardson ratio: the children's r^2 errors over the parent's minus theirs, i.e. the
    // spread within the children over the spread between them (1/3 for uniform light).
    const bool lit = node.weight[0] != 0 || node.weight[1] != 0 || node.weight[2] != 0;
    double within = 0, between = 0;
    for (int j = 0; j < node.child_count; ++j) {
      const FastReference::Node& ch = nodes[node.first_child + j];
      within += child[j].Spread(ch.centre);
      double lum = 0;
      for (int k = 0; k < 3; ++k) lum += kLuminance[k] * ch.weight[k];
      const Vec3 d = ch.centre - c;
      between += (lit ? std::max(lum, 0.0) : 1.0) * d.Dot(d);
    }
    // Also bounded below: a node whose children hold little spread is still a point rule.
    node.richardson = static_cast<float>(between > within / kMaxRichardson
                                             ? std::max(within / between, kMinRichardson)
                                             : std::numeric_limits<double>::infinity());
  }
  // Gradient correction: rho-hat's gradient g at the centre is fitted to the children's values
  // (least squares in the tangent plane, Delta rho_j = g . (c_j - c)), so
  // g . offset = sum_j Delta rho_j (G_j . offset) with G_j = M^+ p_j, M = sum_j p_j p_j^T.
  const Vec3 a = Perpendicular(c), b = c.Cross(a);
  std::array<std::array<double, 2>, 4> p{};
  double m00 = 0, m01 = 0, m11 = 0;
  for (int j = 0; j < node.child_count; ++j) {
    const Vec3 d = nodes[node.first_child + j].centre - c;
    p[j] = {d.Dot(a), d.Dot(b)};
    m00 += p[j][0] * p[j][0];
    m01 += p[j][0] * p[j][1];
    m11 += p[j][1] * p[j][1];
  }
  // Pseudo-inverse of the symmetric 2 x 2 M (children on a line give a rank-1 M).
  // sqrt(a^2 + b^2) rather than std::hypot (~2 ms a build): the entries are sums of squared
  // offsets of unit vectors, far from overflow and underflow.
  const auto norm2 = [](double u, double t) { return std::sqrt(u * u + t * t); };
  const double tr = m00 + m11, disc = norm2(m00 - m11, 2 * m01);
  const double lambda[2] = {0.5 * (tr + disc), 0.5 * (tr - disc)};
  if (!(lambda[0] > 0)) return;
  double inv00 = 0, inv01 = 0, inv11 = 0;
  if (lambda[1] > kWellConditioned * lambda[0]) {
    // Both eigenvalues kept (the usual four quadrants): the pseudo-inverse is the inverse.
    const double inv_det = 1 / (m00 * m11 - m01 * m01);
    inv00 = m11 * inv_det;
    inv01 = -m01 * inv_det;
    inv11 = m00 * inv_det;
  } else {
    for (double l : lambda) {
      if (l <= kGradientRankTolerance * lambda[0]) continue;
      double ex = m01, ey = l - m00;
      if (norm2(ex, ey) < norm2(l - m11, m01)) {
        ex = l - m11;
        ey = m01;
      }
      const double len = norm2(ex, ey);
      if (len == 0) {  // M = l I
        inv00 += 1 / l;
        inv11 += 1 / l;
        continue;
      }
      ex /= len;
      ey /= len;
      inv00 += ex * ex / l;
      inv01 += ex * ey / l;
      inv11 += ey * ey / l;
    }
  }
  // The channels' first moments about the node's centre and, summed, about the children's.
  std::array<Vec3, 3> parent_offset, children_offset;
  for (int ch = 0; ch < 3; ++ch) {
    parent_offset[ch] = sums.Offset(ch, c);
    children_offset[ch] = Vec3{};
    for (int k = 0; k < node.child_count; ++k) {
      children_offset[ch] =
          children_offset[ch] + child[k].Offset(ch, nodes[node.first_child + k].centre);
    }
  }
  FastReference::Gradient g;
  for (int j = 0; j < 4; ++j) {
    Vec3 gj;
    if (j < node.child_count) {
      gj = a * (inv00 * p[j][0] + inv01 * p[j][1]) + b * (inv01 * p[j][0] + inv11 * p[j][1]);
    }
    for (int ch = 0; ch < 3; ++ch) {
      g.parent[ch][j] = static_cast<float>(gj.Dot(parent_offset[ch]));
      g.children[ch][j] = static_cast<float>(gj.Dot(children_offset[ch]));
    }
  }
  node.gradient = static_cast<int32_t>(gradients.size());
  gradients.push_back(g);
}

// The nodes' caps (Create, after the sums and centres): a leaf's radius from its largest squared
// chord (left in `radius` by the build), an internal node's from its children's, then sin_radius
// and cos_open. Every sample of a child lies within the child's radius of its centre, so within
// the angle from the parent's centre to the child's plus that radius (tight for uniform light).
// The arcsines, sines and cosines of a chunk of nodes are computed together (vector math, within
// 4 ulp: far inside kGeometrySlack), the chunks in reverse node order (a node's children are
// numbered after it, so their radii are known before its own).
void SetRadii(std::vector<FastReference::Node>& nodes) {
  constexpr int kChunk = 64;
  std::array<double, 4 * kChunk> half, angle;
  std::array<int, kChunk> offset;
  std::array<double, kChunk> radius, open, sin_r, cos_r, sin_o, cos_o;
  for (int64_t hi = static_cast<int64_t>(nodes.size()); hi > 0; hi -= kChunk) {
    const int64_t lo = std::max<int64_t>(0, hi - kChunk);
    int m = 0;
    for (int64_t i = lo; i < hi; ++i) {
      const FastReference::Node& node = nodes[i];
      offset[i - lo] = m;
      if (node.child_count == 0) {
        half[m++] = std::min(1.0, 0.5 * std::sqrt(node.radius));
      } else {
        for (int g = 0; g < node.child_count; ++g) {
          half[m++] =
              std::min(1.0, 0.5 * (node.centre - nodes[node.first_child + g].centre).Norm());
        }
      }
    }
    internal::VectorAsin(half.data(), angle.data(), m);
    for (int64_t i = hi - 1; i >= lo; --i) {
      FastReference::Node& node = nodes[i];
      const double* a = angle.data() + offset[i - lo];
      double r = 0;
      if (node.child_count == 0) {
        // Angle is increasing in the chord: the largest chord's angle is the largest angle.
        r = 2 * a[0] + kGeometrySlack;
      } else {
        for (int g = 0; g < node.child_count; ++g) {
          r = std::max(r, 2 * a[g] + nodes[node.first_child + g].radius);
        }
      }
      node.radius = std::min(r, kPi);
      radius[i - lo] = node.radius;
      open[i - lo] = node.radius / kFastReferenceEta;
    }
    const int n = static_cast<int>(hi - lo);
    internal::VectorSinCos(radius.data(), sin_r.data(), cos_r.data(), n);
    internal::VectorSinCos(open.data(), sin_o.data(), cos_o.data(), n);
    for (int64_t i = lo; i < hi; ++i) {
      FastReference::Node& node = nodes[i];
      const int k = static_cast<int>(i - lo);
      // Beyond pi/2 the horizon test would need the cap's far side: mark such nodes as always
      // straddling (sin_radius = 1 fails |N.c| > sin_radius).
      node.sin_radius = radius[k] < kPi / 2 ? sin_r[k] : 1.0;
      node.cos_open = open[k] < kPi ? cos_o[k] - kGeometrySlack : -2.0;
    }
  }
}

// A node in the heap: its value (children as points), error estimate and the children's rho-hat
// (reused as their own point values when the node is opened).
struct Record {
  int32_t node;
  Rgb value, error;
  std::array<Rgb, 4> child_rho;
};
struct HeapEntry {
  double priority;
  int32_t record;
  bool operator<(const HeapEntry& o) const { return priority < o.priority; }
};

enum class Mode { kReflection, kTangentProfile, kExact };

// One query: the geometry, the feature description and the running sums.
class QueryState {
 public:
  QueryState(const Brdf& brdf, const Vec3& n, const Vec3& v,
             const FastReference::SampleStore& samples,
             const std::vector<FastReference::Node>& nodes,
             const std::vector<FastReference::Gradient>& gradients, const Rgb& inv_total)
      : brdf_(brdf),
        n_(n),
        v_(v),
        samples_(samples),
        nodes_(nodes),
        gradients_(gradients),
        inv_total_(inv_total),
        channels_(brdf.channels()) {
    if (brdf.reparam() == ReparamKind::kTangent) {
      mode_ = brdf.azimuth_independent() ? Mode::kTangentProfile : Mode::kExact;
      if (mode_ == Mode::kTangentProfile) SetUpProfile();
    } else {
      mode_ = Mode::kReflection;
      // Radially symmetric models (Phong, eq. 5.26) do not depend on N.w at all; every other
      // kReflection model is f_r max(N.w, 0) and may jump there.
      horizon_ = brdf.clipped_at_normal_horizon() || !brdf.radially_symmetric();
      cull_ = brdf.clipped_at_normal_horizon();
      SetUpLobe();
    }
  }

  Mode mode() const { return mode_; }
  size_t evaluations() const { return evaluations_; }

  // rho-hat at w for the three colours (a grey model is evaluated once).
  void Rho(const Vec3& w, Rgb& out) {
    ++evaluations_;
    if (channels_ == 1) {
      out[0] = out[1] = out[2] = brdf_.Transfer(n_, v_, w, 0);
    } else {
      for (int c = 0; c < 3; ++c) out[c] = brdf_.Transfer(n_, v_, w, std::min(c, channels_ - 1));
    }
  }
  // Rho at count <= kMaxBatch directions, through Brdf::TransferMany: up to four siblings'
  // children and centres, or straddling nodes' probes (Process).
  // StraddlingProbes: four children's centres, three cap points, four horizon points.
  static constexpr int kStraddleProbes = 4 + 3 + 4;
  static constexpr int kMaxBatch = 4 * kStraddleProbes;
  void RhoMany(const Vec3* w, int count, Rgb* out) {
    evaluations_ += count;
    std::array<double, kMaxBatch> rho;
    const std::span<const Vec3> dirs(w, count);
    for (int c = 0; c < (channels_ == 1 ? 1 : 3); ++c) {
      brdf_.TransferMany(n_, v_, dirs, std::min(c, channels_ - 1), rho.data());
      for (int k = 0; k < count; ++k) {
        if (channels_ == 1) {
          out[k] = {rho[k], rho[k], rho[k]};
        } else {
          out[k][c] = rho[k];
        }
      }
    }
  }
  double RhoSum(const Vec3& w) {
    Rgb r;
    Rho(w, r);
    return r[0] + r[1] + r[2];
  }

  // A leaf's samples, kLeafBatch at a time through Brdf::TransferMany (a grey model once for the
  // three colours).
  void AddLeaf(const FastReference::Node& node) {
    constexpr int kLeafBatch = kFastReferenceLeafSamples;
    std::array<Vec3, kLeafBatch> dirs;
    std::array<std::array<float, 3>, kLeafBatch> weights;
    std::array<double, kLeafBatch> rho;
    for (int32_t first = node.begin; first < node.end; first += kLeafBatch) {
      const int count = std::min<int32_t>(kLeafBatch, node.end - first);
      samples_.LeafSamples(first, count, dirs.data(), weights.data());
      evaluations_ += count;
      const std::span<const Vec3> w(dirs.data(), count);
      // The batch's sums in four partial sums per channel (independent chains), then added.
      constexpr int kPartials = 4;
      double part[kPartials][3] = {};
      for (int c = 0; c < (channels_ == 1 ? 1 : 3); ++c) {
        brdf_.TransferMany(n_, v_, w, std::min(c, channels_ - 1), rho.data());
        for (int k = 0; k < count; ++k) {
          const std::array<float, 3>& weight = weights[k];
          if (channels_ == 1) {
            for (int cc = 0; cc < 3; ++cc) part[k % kPartials][cc] += weight[cc] * rho[k];
          } else {
            part[k % kPartials][c] += weight[c] * rho[k];
          }
        }
      }
      for (int c = 0; c < 3; ++c)
        total_[c] += (part[0][c] + part[1][c]) + (part[2][c] + part[3][c]);
    }
  }

  // Before a node's children are processed: the samples of those that are leaves are fetched
  // (a leaf's sum waits on them: a lat-long leaf's pixels lie in four rows of the map).
  void PrefetchLeaves(const FastReference::Node& node) const {
    for (int32_t k = 0; k < node.child_count; ++k) {
      const FastReference::Node& child = nodes_[node.first_child + k];
      if (child.child_count == 0) samples_.Prefetch(child.begin, child.end - child.begin);
    }
  }

  // What Process does with a node: skipped (exact zero), summed (leaf), opened (not admissible),
  // bounded (AddStraddling) or evaluated as points and put in the heap (AddPoint).
  enum class Action { kSkip, kLeaf, kOpen, kStraddle, kPoint };
  Action Classify(const FastReference::Node& node) const {
    if (node.weight[0] == 0 && node.weight[1] == 0 && node.weight[2] == 0) return Action::kSkip;
    if (cull_ && n_.Dot(node.centre) < -node.sin_radius - kGeometrySlack) return Action::kSkip;
    if (node.child_count == 0) return Action::kLeaf;
    // Either way the children are read next (opened, or evaluated as points with the gradient):
    // their block and the gradient are fetched while the admissibility test runs (a query is
    // bound by these scattered reads, not by its arithmetic).
    const char* kids = reinterpret_cast<const char*>(&nodes_[node.first_child]);
    for (size_t b = 0; b < node.child_count * sizeof(FastReference::Node); b += 64)
      __builtin_prefetch(kids + b);
    if (node.gradient >= 0) {
      const char* g = reinterpret_cast<const char*>(&gradients_[node.gradient]);
      for (size_t b = 0; b < sizeof(FastReference::Gradient); b += 64) __builtin_prefetch(g + b);
    }
    const bool straddles =
        horizon_ && std::abs(n_.Dot(node.centre)) <= node.sin_radius + kGeometrySlack;
    if (straddles ? !(bound_straddling_ && LobeAdmissible(node)) : !Admissible(node))
      return Action::kOpen;
    return straddles ? Action::kStraddle : Action::kPoint;
  }

  // Processes nodes [first, first + count) (siblings, count <= 4), each as Classify says.
  // `rho`, when given, holds rho-hat at their centres (computed by their parent's check). The
  // siblings' evaluations (a point's children's centres, and its own centre when not given; a
  // straddling node's probes) are made in one batch: one TransferMany call of up to 44
  // directions instead of one or two per sibling of 4-7, whose call overheads and idle vector
  // lanes cost more than the arithmetic. Each sibling's record is still pushed in order.
  void Process(int32_t first, int count, const Rgb* rho) {
    std::array<Action, 4> action;
    std::array<int, 4> offset, probes;
    std::array<Vec3, kMaxBatch> at;
    std::array<Rgb, kMaxBatch> got;
    int batch = 0;
    for (int k = 0; k < count; ++k) {
      const FastReference::Node& node = nodes_[first + k];
      action[k] = Classify(node);
      offset[k] = batch;
      if (action[k] == Action::kStraddle) {
        probes[k] = StraddlingProbes(node, at.data() + batch);
        batch += probes[k];
      } else if (action[k] == Action::kPoint) {
        for (int32_t j = 0; j < node.child_count; ++j)
          at[batch++] = nodes_[node.first_child + j].centre;
        if (rho == nullptr) at[batch++] = node.centre;
      }
    }
    if (batch > 0) RhoMany(at.data(), batch, got.data());
    for (int k = 0; k < count; ++k) {
      const FastReference::Node& node = nodes_[first + k];
      switch (action[k]) {
        case Action::kSkip:
          break;
        case Action::kLeaf:
          AddLeaf(node);
          break;
        case Action::kOpen:
          PrefetchLeaves(node);
          Process(node.first_child, node.child_count, nullptr);
          break;
        case Action::kStraddle:
          AddStraddling(first + k, node, got.data() + offset[k], probes[k]);
          break;
        case Action::kPoint: {
          const Rgb* children = got.data() + offset[k];
          AddPoint(first + k, node, rho != nullptr ? rho[k] : children[node.child_count], children);
          break;
        }
      }
    }
  }

  // Node i as points: its value (children as points) and the error estimate |parent point -
  // children| into the heap, from rho-hat at its centre (r) and at its children's (child_rho).
  void AddPoint(int32_t i, const FastReference::Node& node, const Rgb& r, const Rgb* child_rho) {
    Record rec;
    rec.node = i;
    Rgb point;
    for (int c = 0; c < 3; ++c) point[c] = node.weight[c] * r[c];
    rec.value = {0, 0, 0};
    for (int32_t k = 0; k < node.child_count; ++k) {
      const FastReference::Node& child = nodes_[node.first_child + k];
      rec.child_rho[k] = child_rho[k];
      for (int c = 0; c < 3; ++c) rec.value[c] += child.weight[c] * rec.child_rho[k][c];
    }
    if (node.gradient >= 0) {  // first-order terms of the channels' own centroids
      const FastReference::Gradient& g = gradients_[node.gradient];
      for (int32_t k = 0; k < node.child_count; ++k)
        for (int c = 0; c < 3; ++c) {
          const double delta = rec.child_rho[k][c] - r[c];
          point[c] += delta * g.parent[c][k];
          rec.value[c] += delta * g.children[c][k];
        }
    }
    for (int c = 0; c < 3; ++c) {
      // Richardson: with errors proportional to the light's spread, Q's error is
      // ratio x (Q - P), ratio = spread within the children / spread between them.
      const double delta = node.richardson * (rec.value[c] - point[c]);
      rec.error[c] = kFastReferenceErrorSafety * std::abs(delta);
      rec.value[c] += delta;
    }
    Push(rec);
  }

  // Counts a record's value and error and puts it in the heap by its weighted error.
  void Push(const Record& rec) {
    double priority = 0;
    for (int c = 0; c < 3; ++c) {
      priority += rec.error[c] * inv_total_[c];
      total_[c] += rec.value[c];
      error_[c] += rec.error[c];
    }
    heap_.push_back({priority, static_cast<int32_t>(records_.size())});
    records_.push_back(rec);
    std::push_heap(heap_.begin(), heap_.end());
  }

  // A node that N's horizon cuts (of a model that jumps there), far enough from the lobe for
  // rho-hat to vary slowly across it but for the cut: its children as points (zero below the
  // horizon of a clipped model), and as its error the whole node's light times kStraddleSafety
  // times the largest |rho-hat| on it, taken at the children's centres, at the cap's points
  // nearest the lobe's axis, N and their bisector, and at the horizon's points nearest the
  // centre and the axis (on both sides of a model that is not clipped). Whatever the light's
  // layout within the node, |value - children as points| is within that; most of the horizon's
  // nodes sit where rho-hat is negligible, and only those whose bound matters are refined
  // (before session 39 every node the horizon cut was opened down to its leaves: about half of
  // a microfacet query's evaluations).
  // The directions AddStraddling needs rho-hat at, into `at` (at most kStraddleProbes): the
  // node's children's centres first, then the probes. Returns their count.
  int StraddlingProbes(const FastReference::Node& node, Vec3* at) const {
    int count = 0;
    for (int32_t k = 0; k < node.child_count; ++k)
      at[count++] = nodes_[node.first_child + k].centre;
    // The cap's points nearest the lobe's axis, N (the cosine's peak) and their bisector: the
    // centre turned towards each by the radius (or the direction itself when the cap holds it).
    // The cap's sine is the node's; its radius is below pi / 2 here (LobeAdmissible: r <= eta pi),
    // so its cosine is positive, and d lies beyond the cap when its angle's tangent exceeds the
    // radius's (or it is pi / 2 or more away): no trigonometry per probe.
    const Vec3& c0 = node.centre;
    const double sin_r = node.sin_radius, cos_r = std::sqrt(std::max(0.0, 1 - sin_r * sin_r));
    const auto nearest_to = [&](const Vec3& d) {
      const double cos_to = c0.Dot(d);
      Vec3 toward = d - c0 * cos_to;
      const double sin_to = toward.Norm();
      const bool beyond = cos_to <= 0 || sin_to * cos_r > cos_to * sin_r;
      if (!beyond || !(sin_to > 0)) return d;
      return c0 * cos_r + toward * (sin_r / sin_to);
    };
    const Vec3 mid = axis_ + n_;
    const Vec3 nearest_axis = nearest_to(axis_);
    at[count++] = nearest_axis;
    at[count++] = nearest_to(n_);
    at[count++] = nearest_to(mid.Norm() > 0 ? mid.Normalized() : n_);
    // The horizon's points nearest the centre and the axis, just above it (and below, for a model
    // that is not clipped).
    for (const Vec3& p : {c0, nearest_axis}) {
      Vec3 h = p - n_ * n_.Dot(p);
      const double len = h.Norm();
      if (!(len > 0)) continue;
      h = h * (1.0 / len);
      for (double side : {1.0, -1.0}) {
        if (side < 0 && cull_) break;
        at[count++] = (h + n_ * (side * kHorizonNudge)).Normalized();
      }
    }
    return count;
  }
  // Node i, which N's horizon cuts, from rho-hat at its StraddlingProbes (`got`, `probes` of
  // them): its children as points, and as its error bound its light times kStraddleSafety times
  // the largest |rho-hat| probed.
  void AddStraddling(int32_t i, const FastReference::Node& node, const Rgb* got, int probes) {
    Record rec;
    rec.node = i;
    rec.value = {0, 0, 0};
    Rgb largest{0, 0, 0};
    for (int k = 0; k < probes; ++k)
      for (int c = 0; c < 3; ++c) largest[c] = std::max(largest[c], std::abs(got[k][c]));
    for (int32_t k = 0; k < node.child_count; ++k) {
      const FastReference::Node& child = nodes_[node.first_child + k];
      rec.child_rho[k] = got[k];
      for (int c = 0; c < 3; ++c) rec.value[c] += child.weight[c] * rec.child_rho[k][c];
    }
    for (int c = 0; c < 3; ++c)
      rec.error[c] = kStraddleSafety * std::abs(node.weight[c]) * largest[c];
    Push(rec);
  }

  // Refines the node with the largest error estimate until the estimate meets the target.
  Rgb Run(std::span<const int32_t> roots, double tolerance, const Rgb& floor) {
    if (mode_ == Mode::kExact) {
      FastReference::Node all;
      all.begin = 0;
      all.end = static_cast<int32_t>(samples_.size());
      AddLeaf(all);
      return total_;
    }
    heap_.reserve(4096);
    records_.reserve(4096);
    for (int32_t r : roots) Process(r, 1, nullptr);
    while (!heap_.empty()) {
      bool done = true;
      for (int c = 0; c < 3; ++c)
        if (error_[c] > tolerance * std::max(std::abs(total_[c]), floor[c])) done = false;
      if (done) break;
      std::pop_heap(heap_.begin(), heap_.end());
      const Record rec = records_[heap_.back().record];
      heap_.pop_back();
      for (int c = 0; c < 3; ++c) {
        total_[c] -= rec.value[c];
        error_[c] -= rec.error[c];
      }
      const FastReference::Node& node = nodes_[rec.node];
      PrefetchLeaves(node);
      Process(node.first_child, node.child_count, rec.child_rho.data());
    }
    return total_;
  }

 private:
  bool Admissible(const FastReference::Node& node) const {
    if (!(node.richardson < std::numeric_limits<float>::infinity())) return false;
    if (horizon_ && std::abs(n_.Dot(node.centre)) <= node.sin_radius + kGeometrySlack) return false;
    return LobeAdmissible(node);
  }
  // Test (b) of the header: the node is small against its distance to the lobe's feature.
  bool LobeAdmissible(const FastReference::Node& node) const {
    const double r = node.radius;
    if (mode_ == Mode::kReflection) {
      // r <= eta max(d, w): d >= r / eta is cos d <= cos(r / eta) (no trigonometry per node).
      return r <= kFastReferenceEta * scale_ || node.centre.Dot(axis_) <= node.cos_open;
    }
    // kTangentProfile: the peak cone theta_i = theta* (a line feature) and the cone points +-T.
    // A node straddling the cone has r >= its distance to it, so it passes only when r <= eta w:
    // the peak is resolved.
    const double theta = Angle(node.centre, n_);
    const double to_cone = std::max(0.0, std::abs(theta - theta_star_) - theta_margin_);
    if (r > kFastReferenceEta * std::max(to_cone, scale_)) return false;
    return r <= kFastReferenceEta * std::max(std::min(theta, kPi - theta), scale_);
  }

  void SetUpLobe() {
    axis_ = n_ * (2 * n_.Dot(v_)) - v_;
    const double len = axis_.Norm();
    axis_ = len > 0 ? axis_ * (1.0 / len) : n_;
    if (horizon_) {
      // Does rho-hat jump at the horizon (the simplified microfacet of eq. 5.34)? Probed below the
      // lobe's axis. A node the horizon cuts is bounded (AddStraddling) only then: where rho-hat
      // falls to zero at the horizon, the bound is about as large as the node's whole
      // contribution and the node is refined anyway (measured: GGX and Lambert queries no quicker
      // for it, microfacet's 1.4-2x quicker).
      Vec3 h = axis_ - n_ * n_.Dot(axis_);
      h = h.Norm() > 1e-9 ? h.Normalized() : Perpendicular(n_);
      const double at = RhoSum((h + n_ * kHorizonNudge).Normalized());
      const double above =
          RhoSum((h * std::cos(kJumpProbeHeight) + n_ * std::sin(kJumpProbeHeight)));
      bound_straddling_ = std::abs(at) >= kJumpRatio * std::abs(above);
    }
    scale_ = 0;
    const double peak = RhoSum(axis_);
    if (!(peak > 0)) return;
    Vec3 u = n_ - axis_ * n_.Dot(axis_);
    u = u.Norm() > 1e-9 ? u.Normalized() : Perpendicular(axis_);
    const Vec3 u2 = axis_.Cross(u);
    scale_ = kPi / 2;
    for (const Vec3& dir : {u, u * -1.0, u2, u2 * -1.0}) {
      double last = 0;
      for (double t = kProbeMinAngle; t < scale_; t *= kProbeStep) {
        const double val = RhoSum(axis_ * std::cos(t) + dir * std::sin(t));
        if (!(val * kProbeFactor >= peak && val <= kProbeFactor * peak)) break;
        last = t;
      }
      scale_ = std::min(scale_, last);
    }
  }

  void SetUpProfile() {
    Vec3 p = v_ - n_ * v_.Dot(n_);
    p = p.Norm() > 1e-9 ? p.Normalized() : Perpendicular(n_);
    std::vector<double> g(kProfileSamples);
    const double step = kPi / kProfileSamples;
    int best = 0;
    for (int j = 0; j < kProfileSamples; ++j) {
      const double t = (j + 0.5) * step;
      g[j] = RhoSum(n_ * std::cos(t) + p * std::sin(t));
      if (g[j] > g[best]) best = j;
    }
    if (!(g[best] > 0)) {
      mode_ = Mode::kExact;  // no visible peak on the grid: nothing to steer by
      return;
    }
    theta_star_ = (best + 0.5) * step;
    theta_margin_ = step;
    int lo = best, hi = best;
    while (lo > 0 && g[lo - 1] * kProbeFactor >= g[best]) --lo;
    while (hi + 1 < kProfileSamples && g[hi + 1] * kProbeFactor >= g[best]) ++hi;
    scale_ = std::max(0.0, std::min(best - lo, hi - best) * step - step);
  }

  const Brdf& brdf_;
  const Vec3 n_, v_;
  const FastReference::SampleStore& samples_;
  const std::vector<FastReference::Node>& nodes_;
  const std::vector<FastReference::Gradient>& gradients_;
  const Rgb inv_total_;
  const int channels_;
  Mode mode_ = Mode::kReflection;
  bool horizon_ = false, cull_ = false;
  bool bound_straddling_ = false;  // nodes the horizon cuts are bounded, not opened
  Vec3 axis_;
  double scale_ = 0;  // the lobe's angular scale (0: unknown)
  double theta_star_ = 0, theta_margin_ = 0;
  size_t evaluations_ = 0;
  Rgb total_{0, 0, 0}, error_{0, 0, 0};
  std::vector<HeapEntry> heap_;
  std::vector<Record> records_;
};

}  // namespace

struct FastReference::QueryStats {
  size_t evaluations = 0;
};

absl::StatusOr<FastReference> FastReference::Create(std::span<const EnvSample> samples) {
  return CreateFrom(samples.size(), [samples](size_t i) { return samples[i]; });
}

absl::StatusOr<FastReference> FastReference::Create(const EnvMap& env, int expected_queries) {
  if (env.lat_long_image() != nullptr) {
    const LatLongSampler sampler(env);
    const auto at = [&sampler](size_t i) { return sampler.At(i); };
    const int w = env.width(), h = env.height();
    // A W x W/2 map, W/2 a power of two: its two W/2 x W/2 halves (azimuth) are quadtrees of
    // themselves, their Morton order made directly (no keys computed from directions, no sort).
    if (expected_queries <= kLatLongTreeMaxQueries && w == 2 * h && h >= 4 &&
        std::has_single_bit(static_cast<unsigned>(h)) && h <= (1 << kMortonBits)) {
      const int bits = std::countr_zero(static_cast<unsigned>(h));
      const size_t n = static_cast<size_t>(w) * h;
      Ordered ordered;
      ordered.face_shift = 2 * bits;
      ordered.count = n;
      return CreateFrom(std::move(ordered), at, &sampler, env.lat_long_pixels());
    }
    return CreateFrom(sampler.size(), at);
  }
  return Create(env.samples());
}

absl::StatusOr<FastReference> FastReference::CreateFrom(
    size_t n, absl::FunctionRef<EnvSample(size_t)> sample_at) {
  if (n == 0) return absl::InvalidArgumentError("fast reference: no environment samples");
  if (n > static_cast<size_t>(INT32_MAX)) {
    return absl::InvalidArgumentError(absl::StrCat("fast reference: ", n, " samples (too many)"));
  }
  // Morton keys of the cube faces with their indices beside them, sorted: Morton order, ties by
  // index. A sample with a bad direction gets any key: CreateFrom(Ordered) refuses it.
  std::vector<std::pair<uint64_t, int32_t>> keyed(n);
  for (size_t i = 0; i < n; ++i) {
    const EnvSample s = sample_at(i);
    uint64_t key = 0;
    const double norm = s.dir.Norm();
    if (std::isfinite(norm) && norm > 0) {
      int face;
      double u, t;
      CubeFaceCoordinates(s.dir, &face, &u, &t);
      key = (static_cast<uint64_t>(face) << (2 * kMortonBits)) | Spread(Quantize(u)) |
            (Spread(Quantize(t)) << 1);
    }
    keyed[i] = {key, static_cast<int32_t>(i)};
  }
  SortByKey(keyed);
  Ordered ordered;
  ordered.face_shift = 2 * kMortonBits;
  ordered.count = n;
  ordered.key.resize(n);
  ordered.index.resize(n);
  for (size_t k = 0; k < n; ++k) {
    ordered.key[k] = keyed[k].first;
    ordered.index[k] = keyed[k].second;
  }
  std::vector<std::pair<uint64_t, int32_t>>().swap(keyed);
  return CreateFrom(std::move(ordered), sample_at);
}

void FastReference::SampleStore::PixelOf(int32_t k, int* row, int* col) const {
  // Position k of the tree: half k >> 2 bits (azimuth), then the Morton code of (row, column)
  // within the half's height x height square.
  const uint64_t code = static_cast<uint64_t>(k) & ((uint64_t{1} << (2 * row_bits)) - 1);
  *row = static_cast<int>(Compact(code >> 1));
  *col = static_cast<int>((static_cast<uint64_t>(k) >> (2 * row_bits)) * height + Compact(code));
}

Vec3 FastReference::SampleStore::Dir(int32_t k) const {
  if (height == 0) return list[k].Dir();
  int row, col;
  PixelOf(k, &row, &col);
  const double s = row_sin[row];
  return {s * col_sin[col], row_cos[row], -s * col_cos[col]};
}

void FastReference::SampleStore::LeafSamples(int32_t begin, int count, Vec3* dirs,
                                             std::array<float, 3>* weights) const {
  if (height == 0 || count != 16 || begin % 16 != 0) {
    for (int j = 0; j < count; ++j) {
      dirs[j] = Dir(begin + j);
      weights[j] = Weight(begin + j);
    }
    return;
  }
  // An aligned block of 16: a 4 x 4 block of pixels, row by row (a leaf's sum does not depend
  // on the order), its rows' and columns' factors read once and each row's 12 values converted
  // in one run.
  int row, col;
  PixelOf(begin, &row, &col);
  double cs[4], cc[4];
  for (int t = 0; t < 4; ++t) {
    cs[t] = col_sin[col + t];
    cc[t] = col_cos[col + t];
  }
  for (int t = 0; t < 4; ++t) {
    const double rs = row_sin[row + t], rc = row_cos[row + t], omega = row_omega[row + t];
    const float* p = Pixel(row + t, col);
    float w[12];
    for (int q = 0; q < 12; ++q) w[q] = static_cast<float>(p[q] * omega);
    std::memcpy(weights[4 * t].data(), w, sizeof(w));
    for (int u = 0; u < 4; ++u) dirs[4 * t + u] = {rs * cs[u], rc, -rs * cc[u]};
  }
}

// Coordinates and ChannelWeights are a leaf's directions and weights by channel, in position
// order, for the build's sums (made straight into the arrays: going through the samples' Vec3 and
// float triples cost the build ~20%).
void FastReference::SampleStore::Coordinates(int32_t begin, int count, double* x, double* y,
                                             double* z) const {
  if (height == 0 || count != 16 || begin % 16 != 0) {
    for (int j = 0; j < count; ++j) {
      const Vec3 d = Dir(begin + j);
      x[j] = d.x;
      y[j] = d.y;
      z[j] = d.z;
    }
    return;
  }
  int row, col;
  PixelOf(begin, &row, &col);
  for (int j = 0; j < 16; ++j) {
    const int r = row + BlockRow(j), c = col + BlockCol(j);
    x[j] = row_sin[r] * col_sin[c];
    y[j] = row_cos[r];
    z[j] = -row_sin[r] * col_cos[c];
  }
}

void FastReference::SampleStore::ChannelWeights(int32_t begin, int count, double* r, double* g,
                                                double* b) const {
  if (height == 0 || count != 16 || begin % 16 != 0) {
    for (int j = 0; j < count; ++j) {
      const std::array<float, 3> w = Weight(begin + j);
      r[j] = w[0];
      g[j] = w[1];
      b[j] = w[2];
    }
    return;
  }
  int row, col;
  PixelOf(begin, &row, &col);
  for (int j = 0; j < 16; ++j) {
    const std::array<float, 3> w = PixelWeight(row + BlockRow(j), col + BlockCol(j));
    r[j] = w[0];
    g[j] = w[1];
    b[j] = w[2];
  }
}

void FastReference::SampleStore::Prefetch(int32_t begin, int count) const {
  if (height == 0) {
    const char* p = reinterpret_cast<const char*>(list.data() + begin);
    for (size_t b = 0; b < count * sizeof(Sample); b += 64) __builtin_prefetch(p + b);
    return;
  }
  if (count != 16 || begin % 16 != 0) return;
  int row, col;
  PixelOf(begin, &row, &col);
  for (int t = 0; t < 4; ++t) {
    const float* p = Pixel(row + t, col);
    __builtin_prefetch(p);
    __builtin_prefetch(p + 11);  // the run's 48 bytes may cross a line
  }
}

std::array<float, 3> FastReference::SampleStore::Weight(int32_t k) const {
  if (height == 0) return list[k].weight;
  int row, col;
  PixelOf(k, &row, &col);
  return PixelWeight(row, col);
}

absl::StatusOr<FastReference> FastReference::CreateFrom(
    Ordered ordered, absl::FunctionRef<EnvSample(size_t)> sample_at, const LatLongSampler* lat_long,
    std::shared_ptr<const float> lat_long_pixels) {
  const size_t n = ordered.count;
  if (n == 0) return absl::InvalidArgumentError("fast reference: no environment samples");
  if (n > static_cast<size_t>(INT32_MAX)) {
    return absl::InvalidArgumentError(absl::StrCat("fast reference: ", n, " samples (too many)"));
  }
  // Identity keys (no key array): key k is k itself, and every node is an aligned block of 4^j
  // samples, split into four.
  const std::vector<uint64_t>& key = ordered.key;
  const bool identity = key.empty();
  const auto key_at = [&key, identity](size_t k) { return identity ? k : key[k]; };
  const auto split = [&key, identity](int32_t begin, int32_t end, int32_t bounds[5]) {
    if (!identity) return SplitRange(key.data(), begin, end, bounds);
    if (end - begin <= kFastReferenceLeafSamples) return 0;
    const int32_t quarter = (end - begin) / 4;
    for (int g = 0; g <= 4; ++g) bounds[g] = begin + g * quarter;
    return 4;
  };
  FastReference r;
  SampleStore& store = r.samples_;
  if (lat_long != nullptr) {
    store.height = lat_long->height();
    store.row_bits = std::countr_zero(static_cast<unsigned>(store.height));
    store.pixels = std::move(lat_long_pixels);
    store.row_sin.resize(store.height);
    store.row_cos.resize(store.height);
    store.row_omega.resize(store.height);
    for (int row = 0; row < store.height; ++row) {
      store.row_sin[row] = lat_long->RowSin(row);
      store.row_cos[row] = lat_long->RowCos(row);
      const double omega = lat_long->RowSolidAngle(row);
      if (!std::isfinite(omega) || omega < 0) {
        return absl::InvalidArgumentError(absl::StrCat("fast reference: sample ",
                                                       static_cast<size_t>(row) * lat_long->width(),
                                                       " has solid angle ", omega));
      }
      store.row_omega[row] = omega;
    }
    store.col_sin.resize(lat_long->width());
    store.col_cos.resize(lat_long->width());
    for (int col = 0; col < lat_long->width(); ++col) {
      store.col_sin[col] = lat_long->ColSin(col);
      store.col_cos[col] = lat_long->ColCos(col);
    }
  } else {
    store.list.resize(n);
  }
  double solid_angle = 0;
  if (lat_long != nullptr) {
    // The weights are the map's pixels times their rows' solid angles, made where they are read
    // (the leaves below); the totals are the roots' sums, and a non-finite pixel shows in them.
    for (int row = 0; row < store.height; ++row)
      solid_angle += store.row_omega[row] * lat_long->width();
  }
  for (size_t k = 0; lat_long == nullptr && k < n; ++k) {
    const int32_t i = ordered.index[k];
    const EnvSample s = sample_at(i);
    const double norm = s.dir.Norm();
    if (!std::isfinite(norm) || std::abs(norm - 1) > kUnitTolerance) {
      return absl::InvalidArgumentError(absl::StrCat(
          "fast reference: sample ", i, " has a non-unit direction (norm ", norm, ")"));
    }
    if (!std::isfinite(s.solid_angle) || s.solid_angle < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("fast reference: sample ", i, " has solid angle ", s.solid_angle));
    }
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(s.rgb[c])) {
        return absl::InvalidArgumentError(
            absl::StrCat("fast reference: sample ", i, " has non-finite radiance"));
      }
    }
    Sample& out = store.list[k];
    out.dir = {static_cast<float>(s.dir.x), static_cast<float>(s.dir.y),
               static_cast<float>(s.dir.z)};
    for (int c = 0; c < 3; ++c)
      out.weight[c] = static_cast<float>(static_cast<double>(s.rgb[c]) * s.solid_angle);
    solid_angle += s.solid_angle;
  }
  std::vector<int32_t>().swap(ordered.index);

  // The faces' sample ranges (keys sorted, so each face's run is contiguous).
  const int face_shift = ordered.face_shift;
  std::vector<std::pair<int32_t, int32_t>> faces;
  for (int32_t begin = 0; begin < static_cast<int32_t>(n);) {
    const uint64_t face = key_at(begin) >> face_shift;
    int32_t end = begin;
    while (end < static_cast<int32_t>(n) && (key_at(end) >> face_shift) == face) ++end;
    faces.emplace_back(begin, end);
    begin = end;
  }
  // Room for exactly the tree (a counting pass of the same splits): the arrays grown as the
  // tree was built were reallocated and copied into fresh memory, and a bound (2n nodes) put
  // them in a mapping of their own, in small pages; on this VM a fresh page costs more than the
  // work done in it.
  size_t node_count = 0, internal_count = 0;
  auto count = [&split, &node_count, &internal_count](auto&& self, int32_t begin,
                                                      int32_t end) -> void {
    ++node_count;
    int32_t bounds[5];
    const int groups = split(begin, end, bounds);
    if (groups == 0) return;
    ++internal_count;
    for (int g = 0; g < groups; ++g) self(self, bounds[g], bounds[g + 1]);
  };
  for (const auto& [begin, end] : faces) count(count, begin, end);
  r.nodes_.reserve(node_count);
  r.gradients_.reserve(internal_count);

  // The leaf block (MakeLeafBlock) of the 16 x 16 pixel node being built, when the tree is a
  // lat-long map's: its leaves are taken from it. in_block: [begin, end) lies in it.
  const bool leaf_blocks = lat_long != nullptr;
  LeafBlock block;
  int32_t block_begin = -1;
  const auto in_block = [&block_begin](int32_t begin, int32_t end) {
    return block_begin >= 0 && begin >= block_begin && end <= block_begin + kBlockSide * kBlockSide;
  };
  // A leaf (at most kFastReferenceLeafSamples samples, except coincident ones): its sums, and
  // the largest squared chord from its centre (left in `radius` for SetRadii).
  auto leaf = [&r, &block, &block_begin, &in_block](int32_t i, int32_t begin, int32_t end) -> Sums {
    if (in_block(begin, end) && end - begin == kFastReferenceLeafSamples) {
      const int j = (begin - block_begin) / kFastReferenceLeafSamples;
      Node& node = r.nodes_[i];
      node.begin = begin;
      node.end = end;
      node.weight = block.sums[j].weight;
      node.centre = block.centre[j];
      node.radius = block.chord2[j];
      return block.sums[j];
    }
    Sums sums;
    std::array<double, kFastReferenceLeafSamples> x, y, z;
    std::array<std::array<double, kFastReferenceLeafSamples>, 3> w;
    const double* const channels[3] = {w[0].data(), w[1].data(), w[2].data()};
    for (int32_t k = begin; k < end; k += kFastReferenceLeafSamples) {
      const int batch = std::min<int32_t>(kFastReferenceLeafSamples, end - k);
      r.samples_.Coordinates(k, batch, x.data(), y.data(), z.data());
      r.samples_.ChannelWeights(k, batch, w[0].data(), w[1].data(), w[2].data());
      sums.AddBlock(batch, x.data(), y.data(), z.data(), channels);
    }
    Node& node = r.nodes_[i];
    node.begin = begin;
    node.end = end;
    node.weight = sums.weight;
    node.centre = sums.Centre();
    const Vec3 c = node.centre;
    double chord2 = 0;
    if (end - begin <= kFastReferenceLeafSamples) {  // the coordinates are at hand
      for (int j = 0; j < end - begin; ++j) {
        const double dx = x[j] - c.x, dy = y[j] - c.y, dz = z[j] - c.z;
        chord2 = std::max(chord2, dx * dx + dy * dy + dz * dz);
      }
    } else {
      for (int32_t k = begin; k < end; ++k) {
        const Vec3 d = r.samples_.Dir(k) - c;
        chord2 = std::max(chord2, d.Dot(d));
      }
    }
    node.radius = chord2;
    return sums;
  };
  // Fills node i over samples [begin, end) and returns its sums. Nodes are numbered as they are
  // reached top-down (a node, then its children as one block); their values come bottom-up:
  // a leaf's from its samples, an internal node's from its children's sums.
  auto build = [&r, &split, &leaf, leaf_blocks, &block, &block_begin, &in_block](
                   auto&& self, int32_t i, int32_t begin, int32_t end) -> Sums {
    int32_t bounds[5];
    const int groups = split(begin, end, bounds);
    if (groups == 0) return leaf(i, begin, end);
    if (leaf_blocks && end - begin == kBlockSide * kBlockSide) {
      MakeLeafBlock(r.samples_, begin, &block);
      block_begin = begin;
    }
    const int32_t first = static_cast<int32_t>(r.nodes_.size());
    // Within the exact reservation: references to nodes stay valid.
    r.nodes_.resize(r.nodes_.size() + groups);
    Sums sums;
    std::array<Sums, 4> own;
    std::span<const Sums> child;
    if (in_block(begin, end) && end - begin == 4 * kFastReferenceLeafSamples) {
      // Four leaves of the leaf block: their sums are read where the block holds them.
      const int j = (begin - block_begin) / kFastReferenceLeafSamples;
      for (int g = 0; g < 4; ++g) leaf(first + g, bounds[g], bounds[g + 1]);
      child = std::span(block.sums).subspan(j, 4);
      for (const Sums& c : child) sums.Merge(c);
    } else {
      // Children that are leaves: their samples are fetched before the first is summed (a
      // lat-long leaf's pixels lie in four rows of the map, which the hardware does not predict).
      for (int g = 0; g < groups && block_begin < 0; ++g) {
        if (bounds[g + 1] - bounds[g] <= kFastReferenceLeafSamples)
          r.samples_.Prefetch(bounds[g], bounds[g + 1] - bounds[g]);
      }
      for (int g = 0; g < groups; ++g) {
        own[g] = self(self, first + g, bounds[g], bounds[g + 1]);
        sums.Merge(own[g]);
      }
      child = std::span(own).first(groups);
    }
    Node& node = r.nodes_[i];
    node.begin = begin;
    node.end = end;
    node.weight = sums.weight;
    node.centre = sums.Centre();
    node.first_child = first;
    node.child_count = groups;
    SetGradient(r.nodes_, r.gradients_, i, sums, child);
    return sums;
  };
  std::vector<Sums> root_sums;
  for (const auto& [begin, end] : faces) {
    const int32_t root = static_cast<int32_t>(r.nodes_.size());
    r.nodes_.emplace_back();
    r.roots_.push_back(root);
    root_sums.push_back(build(build, root, begin, end));
  }
  SetRadii(r.nodes_);
  Rgb total{0, 0, 0}, total_abs{0, 0, 0};
  for (const Sums& root : root_sums) {
    for (int c = 0; c < 3; ++c) {
      total[c] += root.weight[c];
      total_abs[c] += root.abs_weight[c];
    }
  }
  if (lat_long != nullptr && !(std::isfinite(total_abs[0]) && std::isfinite(total_abs[1]) &&
                               std::isfinite(total_abs[2]))) {
    const float* pixels = store.pixels.get();
    for (size_t i = 0; i < n; ++i) {
      const float* p = pixels + 3 * i;
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
        return absl::InvalidArgumentError(
            absl::StrCat("fast reference: sample ", i, " has non-finite radiance"));
      }
    }
    return absl::InvalidArgumentError("fast reference: the map's total radiance overflows");
  }
  for (int c = 0; c < 3; ++c) {
    const double mean = solid_angle > 0 ? std::abs(total[c]) / solid_angle : 0.0;
    r.floor_[c] = kFastReferenceFloor * mean;
    r.inv_total_[c] = total_abs[c] > 0 ? 1.0 / total_abs[c] : 0.0;
  }
  return r;
}

std::array<double, 3> FastReference::Query(const Brdf& brdf, const Vec3& n, const Vec3& v,
                                           double tolerance, QueryStats* stats) const {
  QueryState q(brdf, n, v, samples_, nodes_, gradients_, inv_total_);
  const Rgb out = q.Run(roots_, tolerance, floor_);
  if (stats != nullptr) stats->evaluations = q.evaluations();
  return out;
}

std::array<double, 3> FastReference::Radiance(const Brdf& brdf, const Mat3& rotation,
                                              const Vec3& index, const Vec3& view,
                                              double relative_tolerance) const {
  const Mat3 inv = rotation.Transposed();
  return Query(brdf, inv * index, inv * view, relative_tolerance, nullptr);
}

std::vector<std::array<double, 3>> FastReference::RadianceMany(
    const Brdf& brdf, const Mat3& rotation, std::span<const Vec3> index, std::span<const Vec3> view,
    int threads, double relative_tolerance) const {
  const size_t count = std::min(index.size(), view.size());
  std::vector<std::array<double, 3>> out(count);
  ParallelChunks(static_cast<int>(count), threads, [&](int begin, int end) {
    for (int i = begin; i < end; ++i)
      out[i] = Radiance(brdf, rotation, index[i], view[i], relative_tolerance);
  });
  return out;
}

size_t FastReference::EvaluationCount(const Brdf& brdf, const Mat3& rotation, const Vec3& index,
                                      const Vec3& view, double relative_tolerance) const {
  const Mat3 inv = rotation.Transposed();
  QueryStats stats;
  Query(brdf, inv * index, inv * view, relative_tolerance, &stats);
  return stats.evaluations;
}

}  // namespace shrm
