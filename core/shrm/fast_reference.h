// Fast reflected-radiance reference: the sum of BrdfReferenceRadiance (shrm_reference.h),
//   B(N, V) = sum_k L_k dOmega_k rho-hat(N, V, w_k)   over every sample of the map,
// computed adaptively over a hierarchy of the samples instead of sample by sample. It stays a
// sum over the whole map (no cone truncation: far samples, e.g. a sun in a GGX tail, are always
// counted) and it converges to the exact sum: refined to its leaves it IS the exact sum.
//
// Hierarchy (Create): samples binned to the six cube faces, a quadtree per face in Morton order
// (every node is a contiguous range of samples, single-child chains collapsed), leaves of at most
// kFastReferenceLeafSamples samples. A W x W/2 lat-long map with W/2 a power of two (the usual
// 1024 x 512) is its own quadtree instead: its two W/2 x W/2 halves in the Morton order of their
// pixels, made without keys or a sort (build 40 -> 17 ms and 19 MB instead of ~40 touched in a
// `shrm prefilter`; a query makes ~1.3x the evaluations in the same time, its pixels' blocks
// narrower near the poles; the same accuracy, tests/fast_reference_test.cc). It stores only the
// samples' weights, a leaf's 4 x 4 pixels read as a block, and makes their directions from the
// map's row and column tables (session 39: build 22 -> 12 ms, 13 MB). Per node: the summed L
// dOmega per channel, the luminance-weighted mean direction c (normalized) and the angular radius r
// of a cap around c that holds every sample (a leaf's exact; an internal node's bounded from its
// children's, max_j angle(c, c_j) + r_j, which is tight for uniform light). The build is linear
// after a radix sort of the keys: a node's split is found from its first and last keys, its sums
// are its children's (bottom-up), and the arrays are reserved at the exact node count.
//
// Query (Radiance): a node used "as a point" contributes its summed weight times rho-hat at c.
// A node is ADMISSIBLE (may be used as points) only when no feature of rho-hat can hide inside it:
//  (a) horizon: it does not straddle the plane of N (|N.c| > sin r + margin) for models that
//      jump or kink there (clipped_at_normal_horizon(), and every kReflection model that is not
//      radially symmetric); nodes wholly below the horizon of a clipped model are skipped (exact
//      zeros). For a model that jumps there (probed per query below the lobe's axis: the
//      simplified microfacet), a node that straddles it but passes (b) is used as its children's
//      points with a bound instead of an estimate: its light times twice the largest |rho-hat|
//      probed on it (its children's centres, the cap's points nearest the lobe's axis, N and
//      their bisector, and the horizon's points nearest the centre and the axis), whatever the
//      light's layout within it. Most of the horizon lies where rho-hat is negligible; only the
//      nodes whose bound matters are refined (session 39: 19k -> 9k evaluations a microfacet
//      query). Where rho-hat falls to zero at the horizon (GGX, Lambert) the bound is about the
//      node's whole contribution and such nodes are opened as before;
//  (b) lobe: r <= eta max(d, w) (Barnes-Hut opening criterion), d the angle from c to the lobe
//      axis R = 2 (N.V) N - V and w the lobe's scale, probed per query: the smallest angle from R
//      (along four great-circle directions) at which rho-hat differs from rho-hat(R) by a factor 2;
//  kTangent models (Kajiya-Kay: `index` is T) that are azimuth_independent() depend on w only
//  through theta_i = angle(T, w). Their profile rho-hat(theta_i) is sampled on a fine grid per
//  query; the peak cone theta_i = theta* is a line feature (r <= eta max(|theta_c - theta*|, w): a
//  node straddling it passes only when r <= eta w, the peak resolved), the cone points +-T are
//  point features as R above. Other kTangent models fall back to the exact sum of all samples.
// A node must also have children that split its light: the spread (second moment of the centroid
// weights about c) within its children must be < kMaxRichardson x the spread between them,
// else (one child holds a lamp) it is opened.
// An admissible node is evaluated at its centre (P) and at its children's centres (Q), both with
// a first-order correction per channel (the gradient of rho-hat fitted to the children's values
// times the channel's first moment about c: the luminance centroid is not every channel's). With
// a point rule's error proportional to the light's spread, Q's error is k (Q - P), k = spread
// within the children / spread between them (1/3 for uniform light): the node's value is
// Q + k (Q - P) (Richardson) and its error estimate e = kFastReferenceErrorSafety |k (Q - P)|.
// Global adaptivity (as QUADPACK's qag): the admissible nodes sit in a max-heap by e; the node
// with the largest e is replaced by its children until, in every channel,
//   sum e <= relative_tolerance x max(|B|, floor),  floor = kFastReferenceFloor x mean radiance,
// B the running total. Leaves are summed exactly (e = 0), so the loop always ends, at the exact
// sum in the worst case. Error argument: the total error is at most the sum of the nodes' errors,
// each bounded by its e wherever rho-hat is resolved by the node's children, which (a), (b) and
// the spread condition enforce near every feature; so the per-direction relative error is
// <= relative_tolerance (measured typically 3-10x below it, 4.8e-4 at worst). Grey BRDFs
// (channels() == 1) are evaluated once per point for all three colours; Transfer is called directly
// (no std::function).
//
// Measured (bench/reference_bench.cc, docs/shrm.md "Fast reference"; 1024 x 512, one core, CPU
// time on a shared machine, session 41, the lat-long tree, at 1e-3): 0.10-0.16 ms per direction
// for Phong, 0.15 ms Lambert, 0.15-0.20 ms microfacet, 0.22-0.26 ms GGX, 0.52 ms Kajiya-Kay
// (4.5k-20k rho-hat evaluations instead of 524288), 53-218x faster than the full sum; largest
// error over the four bundled maps 6.9e-4 (tests/fast_reference_test.cc). The build: ~35 ms and ~27
// MB from a list of samples; ~6 ms and ~5 MB (the nodes: the samples are the map's own pixels) from
// a 1024 x 512 lat-long map (session 41; ~12 ms and ~13 MB in session 39).
#ifndef SHRM_CORE_SHRM_FAST_REFERENCE_H_
#define SHRM_CORE_SHRM_FAST_REFERENCE_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"

namespace shrm {

// Default per-direction relative error target of FastReference::Radiance (the accuracy a job's
// self-check needs: 10x below the SHRM's own approximation errors of ~1e-2).
inline constexpr double kFastReferenceTolerance = 1e-3;
// Error target of the reference in a job's own check (MeasureCubeError) and the report's error
// map. The target bounds the error ESTIMATE, and the errors stay well below it: at the default
// check's 64 pairs, on the four bundled maps x six BRDFs (Phong s = 32, Lambert, microfacet
// sigma 0.1 and 0.2, GGX alpha 0.1 f0 0.04 and alpha 0.3 f0 1), the largest error measured
// against the full pixel sum is 7.3e-4 and the RMS 1.4e-4 (at 1e-3: 7.2e-4 and 1.1e-4;
// tests/fast_reference_test.cc holds it within 2e-3 for 13 models, measured 8.9e-4). The check's
// figures (targets 1% RMS, 5% largest) move by about 1% of a target, far less than a 64-pair
// sample's own spread, and its queries make a third fewer evaluations (microfacet sigma 0.2 on
// courtyard: 9,600 -> 6,400). At 3e-3 the test's worst reached 2.1e-3 (courtyard, Phong s = 8).
inline constexpr double kCheckReferenceTolerance = 2e-3;
// Samples per leaf node: leaves are summed exactly. 16 rather than 4: the tree has a quarter of
// the nodes (91k instead of 312k on a 1024 x 512 map: 14 MB instead of 48, most of the cost of
// a job's check on this VM, where a fresh page costs more than the work done in it), and a query
// visits fewer of them: on interior.exr, 5-30% more rho-hat evaluations but 5-30% less time per
// direction (bench/reference_bench.cc, docs/shrm.md "Fast reference").
inline constexpr int kFastReferenceLeafSamples = 16;
// Opening criterion eta of (b): a node must be smaller than eta times its distance to the lobe
// axis (or than eta times the lobe's scale). Measured: 0.25 keeps the children-vs-parent check
// reliable for GGX's power-law tails and Phong up to s = 512.
inline constexpr double kFastReferenceEta = 0.25;
// Safety factor on the Richardson error estimate of a node (measured errors are 3-10x below the
// estimate; 1.5 covers the non-asymptotic nodes next to a lobe's peak).
inline constexpr double kFastReferenceErrorSafety = 1.5;
// Absolute floor of the error target, as a fraction of the map's mean radiance (per channel):
// it only stops endless refinement of directions whose B is ~0 (far below any metric's floor).
inline constexpr double kFastReferenceFloor = 1e-7;
// Most queries a lat-long map's own quadtree is built for (Create(EnvMap)): about where its
// quicker build stops paying for its dearer queries.
inline constexpr int kLatLongTreeMaxQueries = 384;

class FastReference {
 public:
  // Errors (InvalidArgument): no samples; non-finite or non-unit (|norm - 1| > 1e-6) directions;
  // negative or non-finite solid angles; non-finite radiance.
  static absl::StatusOr<FastReference> Create(std::span<const EnvSample> samples);
  // The same for the samples of `env`: a lat-long map's are computed as they are read
  // (LatLongSampler), never stored whole (EnvMap::samples() would keep 48 bytes per pixel).
  // A W x W/2 lat-long map with W/2 a power of two gets its own quadtree (the header comment)
  // unless `expected_queries` exceeds kLatLongTreeMaxQueries: its build is ~23 ms quicker, its
  // queries up to ~0.06 ms slower (microfacet; 1024 x 512, this machine), so a longer check
  // (`--verify 1024`) keeps the cube faces' tree.
  static absl::StatusOr<FastReference> Create(const EnvMap& env, int expected_queries = 0);

  // BrdfReferenceRadiance(samples, brdf, rotation, index, view) to `relative_tolerance`
  // (per channel, relative to max(|B|, floor)): index = N (or T for kTangent models), view V,
  // environment rotated by `rotation` (L'(w) = L(R^-1 w): the geometry is rotated by R^-1).
  // Grey BRDFs give the same value in all three channels' transfer (channel 0); RGB BRDFs use
  // channel min(c, channels() - 1).
  std::array<double, 3> Radiance(const Brdf& brdf, const Mat3& rotation, const Vec3& index,
                                 const Vec3& view,
                                 double relative_tolerance = kFastReferenceTolerance) const;

  // Radiance for every (index[i], view[i]) (index.size() == view.size()), split over `threads`
  // threads; results in query order and bit-identical for any thread count.
  std::vector<std::array<double, 3>> RadianceMany(
      const Brdf& brdf, const Mat3& rotation, std::span<const Vec3> index,
      std::span<const Vec3> view, int threads,
      double relative_tolerance = kFastReferenceTolerance) const;

  size_t sample_count() const { return samples_.size(); }

  // Statistics of the last queries are not kept; this counts the rho-hat evaluations one query
  // makes (for the benchmark and the docs).
  size_t EvaluationCount(const Brdf& brdf, const Mat3& rotation, const Vec3& index,
                         const Vec3& view,
                         double relative_tolerance = kFastReferenceTolerance) const;

  // A sample in single precision (24 bytes, not 48: the hierarchy's memory is most of a job's
  // check, and a fresh page costs more than the work done in it). Rounding moves a direction by
  // ~1e-7 rad and a weight by 6e-8 relative: far below the 1e-3 the reference is built for.
  struct Sample {
    std::array<float, 3> dir;     // unit direction
    std::array<float, 3> weight;  // L_c dOmega
    Vec3 Dir() const { return {dir[0], dir[1], dir[2]}; }
  };
  struct Node {
    Vec3 centre;                   // luminance-weighted mean direction, unit
    double radius = 0;             // every sample is within this angle of `centre`
    double sin_radius = 0;         // sin(radius), or 1 when radius >= pi/2
    double cos_open = -2;          // cos(radius / eta), -2 when radius / eta >= pi
    std::array<double, 3> weight;  // sum of L_c dOmega
    float richardson = 0;          // Q's error / (Q - P), infinite: never used as points
    int32_t begin = 0, end = 0;    // samples [begin, end)
    int32_t first_child = -1;      // children [first_child, first_child + child_count)
    int32_t child_count = 0;       // 0: a leaf (summed exactly)
    int32_t gradient = -1;         // index into gradients_ (internal nodes)
  };
  // 96 bytes (the ratio in single precision: a factor of an error estimate).
  // First-order correction of an internal node (see Create): with Delta_j = rho-hat at child j's
  // centre minus rho-hat at the node's centre, the node as a point gets + sum_j Delta_j
  // parent[c][j] and the children as points + sum_j Delta_j children[c][j], in channel c.
  // In single precision (96 bytes, not 192: a correction's own rounding at 6e-8 of itself is far
  // below the reference's tolerance, and the tree's fresh memory is most of a check's cost).
  struct Gradient {
    std::array<std::array<float, 4>, 3> parent{}, children{};
  };
  // The samples in tree order (internal to the implementation): a list of Sample, or for a
  // lat-long map's own tree nothing of its own: the map's pixels (shared with the map, so no
  // copy: the fresh memory of a job's check is most of its cost), each weight made from its
  // pixel and its row's solid angle and each direction from its row and column as LatLongSampler
  // makes them (in double precision, the weight then rounded to float as the list's).
  struct SampleStore {
    std::vector<Sample> list;  // the cube faces' tree
    // The lat-long tree: the map's RGB pixels, row-major, and its tables.
    std::shared_ptr<const float> pixels;
    std::vector<double> row_sin, row_cos, col_sin, col_cos, row_omega;
    int height = 0;    // > 0: the lat-long tree of a (2 height) x height map
    int row_bits = 0;  // log2(height)
    size_t size() const {
      return height > 0 ? 2 * static_cast<size_t>(height) * height : list.size();
    }
    // The lat-long tree's position k: its pixel's row and column in the map.
    void PixelOf(int32_t k, int* row, int* col) const;
    Vec3 Dir(int32_t k) const;
    // The directions and weights of positions [begin, begin + count) (a leaf's samples), in an
    // order of their own: an aligned lat-long leaf's row by row (its pixels), others' in position
    // order. For sums, which do not depend on it.
    void LeafSamples(int32_t begin, int count, Vec3* dirs, std::array<float, 3>* weights) const;
    // Dir(begin + j) for j < count as separate coordinates.
    void Coordinates(int32_t begin, int count, double* x, double* y, double* z) const;
    // Starts fetching positions [begin, begin + count) (a leaf's samples) into the cache.
    void Prefetch(int32_t begin, int count) const;
    // L_c dOmega of position k.
    std::array<float, 3> Weight(int32_t k) const;
    // Weight(begin + j) for j < count by channel, in double precision.
    void ChannelWeights(int32_t begin, int count, double* r, double* g, double* b) const;
    // The lat-long tree's pixel (its RGB in the map) and its weight.
    const float* Pixel(int row, int col) const {
      return pixels.get() + 3 * (static_cast<size_t>(row) * 2 * height + col);
    }
    std::array<float, 3> PixelWeight(int row, int col) const {
      const float* p = Pixel(row, col);
      const double omega = row_omega[row];
      return {static_cast<float>(p[0] * omega), static_cast<float>(p[1] * omega),
              static_cast<float>(p[2] * omega)};
    }
  };

 private:
  // Create() over n samples read by index: keyed by cube face and Morton order, sorted.
  static absl::StatusOr<FastReference> CreateFrom(size_t n,
                                                  absl::FunctionRef<EnvSample(size_t)> sample_at);
  // The samples in their tree order: key[k] (ascending; its bits from face_shift up name the
  // root, those below are 2-bit quadtree digits) is sample index[k]'s.
  // Without keys (key empty, only with a LatLongSampler): position k's key is k itself, and its
  // pixel the Morton code's row and column in half k >> face_shift of the map.
  struct Ordered {
    size_t count = 0;
    std::vector<uint64_t> key;
    std::vector<int32_t> index;
    int face_shift = 0;
  };
  // `lat_long`: the identity-keyed tree of that sampler's map (directions from its tables),
  // whose pixels `lat_long_pixels` are (kept by the tree).
  static absl::StatusOr<FastReference> CreateFrom(
      Ordered ordered, absl::FunctionRef<EnvSample(size_t)> sample_at,
      const LatLongSampler* lat_long = nullptr,
      std::shared_ptr<const float> lat_long_pixels = nullptr);
  FastReference() = default;
  struct QueryStats;
  std::array<double, 3> Query(const Brdf& brdf, const Vec3& n, const Vec3& v, double tolerance,
                              QueryStats* stats) const;

  SampleStore samples_;  // in Morton order
  std::vector<Node> nodes_;
  std::vector<Gradient> gradients_;
  std::vector<int32_t> roots_;         // one per non-empty cube face
  std::array<double, 3> floor_{};      // kFastReferenceFloor x mean radiance, per channel
  std::array<double, 3> inv_total_{};  // 1 / sum of |L_c dOmega| (priority weights)
};

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_FAST_REFERENCE_H_
