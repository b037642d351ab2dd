#include "jobs/report_visuals.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/escaping.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/shrm/fast_reference.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/tolerance.h"

namespace shrm::jobs {
namespace {

// Angles of the lobe plot: the view's angle from the normal, and the light's angle sampled
// every kLobeStepDeg across the plane of incidence.
constexpr double kLobeViewsDeg[] = {0, 30, 60};
constexpr int kLobeStepDeg = 2;

struct Frame {
  Vec3 view, right, up;
};

Frame ViewFrame(const Vec3& v) {
  const Vec3 up0 = std::abs(v.y) > 0.99 ? Vec3{0, 0, -1} : Vec3{0, 1, 0};
  const Vec3 right = up0.Cross(v).Normalized();
  return {v, right, v.Cross(right)};
}

// The normal seen at (px, py) in [-1, 1]^2 (x right, y up), or none outside the disc.
std::optional<Vec3> SphereNormal(const Frame& f, double px, double py) {
  const double r2 = px * px + py * py;
  if (r2 >= 1) return std::nullopt;
  return f.right * px + f.up * py + f.view * std::sqrt(1 - r2);
}

// What addresses the cube at normal n: n itself, or for tangent models (hair) the tangent along
// the latitudes.
Vec3 IndexAt(const ShrmCube& cube, const Vec3& n) {
  if (cube.index != ReparamKind::kTangent) return n;
  const Vec3 t = Vec3{0, 1, 0}.Cross(n);
  return t.Norm() > 1e-6 ? t.Normalized() : Vec3{1, 0, 0};
}

nlohmann::json VecJson(const Vec3& v) { return {v.x, v.y, v.z}; }
nlohmann::json RgbJson(const Rgb& c) { return {c[0], c[1], c[2]}; }

// Largest channel of |got - ref| / max(|ref|, floor_c).
double PairError(const Rgb& got, const Rgb& ref, const Rgb& floor) {
  double e = 0;
  for (int c = 0; c < 3; ++c)
    e = std::max(e, std::abs(got[c] - ref[c]) / std::max(std::abs(ref[c]), floor[c]));
  return e;
}

// The PNG of an 8-bit RGBA image, base64 (for data: URIs).
absl::StatusOr<std::string> PngBase64(const Image& rgba01) {
  SHRM_ASSIGN_OR_RETURN(const std::string png, EncodeImage(rgba01, ImageEncoding::kPng8));
  return absl::Base64Escape(png);
}

// Adds an alpha channel: opaque inside the discs of the three spheres.
Image WithDiscAlpha(const Image& rgb, int size) {
  Image out;
  out.width = rgb.width;
  out.height = rgb.height;
  out.channels = 4;
  out.pixels.resize(static_cast<size_t>(out.width) * out.height * 4);
  for (int y = 0; y < rgb.height; ++y)
    for (int x = 0; x < rgb.width; ++x) {
      const double px = 2 * ((x % size) + 0.5) / size - 1, py = 1 - 2 * (y + 0.5) / size;
      float* o = &out.pixels[(static_cast<size_t>(y) * out.width + x) * 4];
      for (int c = 0; c < 3; ++c) o[c] = rgb.at(x, y, c);
      o[3] = px * px + py * py < 1 ? 1.0f : 0.0f;
    }
  return out;
}

Image BlankImage(int width, int height, int channels) {
  Image img;
  img.width = width;
  img.height = height;
  img.channels = channels;
  img.pixels.assign(static_cast<size_t>(width) * height * channels, 0.0f);
  return img;
}

nlohmann::json LobeJson(const Brdf& brdf) {
  nlohmann::json lobe;
  lobe["index"] = brdf.reparam() == ReparamKind::kTangent ? "tangent" : "normal";
  nlohmann::json thetas = nlohmann::json::array(), values = nlohmann::json::array();
  for (int t = -90; t <= 90; t += kLobeStepDeg) thetas.push_back(t);
  for (double tv : kLobeViewsDeg) {
    const double a = tv * kPi / 180;
    const Vec3 n{0, 0, 1}, v{std::sin(a), 0, std::cos(a)};
    nlohmann::json row = nlohmann::json::array();
    for (int t = -90; t <= 90; t += kLobeStepDeg) {
      const double b = t * kPi / 180;
      const Vec3 w{std::sin(b), 0, std::cos(b)};
      double sum = 0;
      for (int c = 0; c < brdf.channels(); ++c) sum += brdf.Transfer(n, v, w, c);
      const double value = sum / brdf.channels();
      row.push_back(std::isfinite(value) ? value : 0.0);
    }
    values.push_back(row);
  }
  lobe["views_deg"] = kLobeViewsDeg;
  lobe["theta_deg"] = thetas;
  lobe["values"] = values;
  return lobe;
}

absl::StatusOr<nlohmann::json> MapJson(const EnvMap& env, int threads) {
  SHRM_ASSIGN_OR_RETURN(Image ll, env.ToLatLong(kThumbnailWidth, threads));
  const Image shown = TonemapPreview(ll, MidGreyExposure(ll));
  SHRM_ASSIGN_OR_RETURN(std::string png, PngBase64(shown));
  return nlohmann::json{{"png", png}, {"width", shown.width}, {"height", shown.height}};
}

}  // namespace

std::array<SphereView, kSphereViews> SphereViews() {
  return {{{"front", {0, 0, 1}}, {"side", {1, 0, 0}}, {"above", Vec3{0, 0.7, 0.7}.Normalized()}}};
}

Image RenderShrmSpheres(const ShrmCube& cube, int size, const Brdf* brdf, int threads) {
  Image img = BlankImage(kSphereViews * size, size, 3);
  const auto views = SphereViews();
  // Each task a run of (view, row) pairs: a preview's 768 rows of SHRM evaluations took 1.3 s of
  // a 3.5 s default job on one thread (courtyard, microfacet sigma 0.3, P_B = 29).
  ParallelChunks(kSphereViews * size, threads, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const int s = row / size, y = row % size;
      const Frame f = ViewFrame(views[s].view);
      for (int x = 0; x < size; ++x) {
        const std::optional<Vec3> n =
            SphereNormal(f, 2 * (x + 0.5) / size - 1, 1 - 2 * (y + 0.5) / size);
        if (!n) continue;
        const Vec3 index = IndexAt(cube, *n);
        const std::array<double, 3> b = brdf != nullptr
                                            ? ShrmEvalWithLights(cube, *brdf, index, f.view)
                                            : ShrmEval(cube, index, f.view);
        for (int c = 0; c < 3; ++c)
          img.pixels[(static_cast<size_t>(y) * img.width + s * size + x) * 3 + c] =
              static_cast<float>(b[c]);
      }
    }
  });
  return img;
}

double MidGreyExposure(const Image& img) {
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i + 2 < img.pixels.size(); i += img.channels) {
    const double lum =
        0.2126 * img.pixels[i] + 0.7152 * img.pixels[i + 1] + 0.0722 * img.pixels[i + 2];
    if (lum > 0 && std::isfinite(lum)) {
      sum += lum;
      ++n;
    }
  }
  return n > 0 && sum > 0 ? std::log2(0.18 * n / sum) : 0.0;
}

std::array<uint8_t, 3> ErrorColour(double t) {
  // Dark blue, purple, red, orange, pale yellow: Rec. 709 luminance 25, 63, 108, 172, 236.
  static constexpr double kStops[5][3] = {
      {20, 24, 90}, {110, 40, 140}, {205, 75, 60}, {245, 160, 40}, {250, 242, 160}};
  t = std::clamp(std::isfinite(t) ? t : 1.0, 0.0, 1.0) * 4;
  const int i = std::min(3, static_cast<int>(t));
  const double f = t - i;
  std::array<uint8_t, 3> out;
  for (int c = 0; c < 3; ++c)
    out[c] =
        static_cast<uint8_t>(std::lround(kStops[i][c] + f * (kStops[i + 1][c] - kStops[i][c])));
  return out;
}

double ErrorScalePosition(double e) {
  if (!(e > 0)) return 0;
  return std::clamp((std::log10(e) - kErrorScaleLow) / (kErrorScaleHigh - kErrorScaleLow), 0.0,
                    1.0);
}

absl::StatusOr<nlohmann::json> PrefilterVisuals(const EnvMap& env, const Brdf& brdf,
                                                const Mat3& rotation, const ShrmCube& cube,
                                                int threads, const FastReference* given) {
  threads = std::max(threads, 1);
  std::optional<FastReference> made;
  if (given == nullptr) {
    SHRM_ASSIGN_OR_RETURN(made, FastReference::Create(env, kReportPairs));
  }
  const FastReference& reference = given != nullptr ? *given : *made;
  nlohmann::json out;
  SHRM_ASSIGN_OR_RETURN(out["map"], MapJson(env, threads));
  out["lobe"] = LobeJson(brdf);

  // The seeded pairs (the job's check takes the first --verify of the same sequence).
  const std::vector<DirectionPair> pairs =
      StratifiedDirectionPairs(kVerifySeed, kReportPairs, brdf.reparam());
  std::vector<Vec3> index, view;
  for (const DirectionPair& p : pairs) {
    index.push_back(p.index);
    view.push_back(p.view);
  }
  const std::vector<Rgb> ref =
      reference.RadianceMany(brdf, rotation, index, view, threads, kCheckReferenceTolerance);
  std::vector<Rgb> got(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k)
    got[k] = ShrmEvalWithLights(cube, brdf, index[k], view[k]);
  Rgb floor = RelativeFloor(pairs, ref);
  for (double& f : floor) f = std::max(f, 1e-300);
  const DirectionalError stats = MeasureDirectionalError(pairs, got, ref);
  nlohmann::json points = nlohmann::json::array();
  for (size_t k = 0; k < pairs.size(); ++k) {
    points.push_back({{"index", VecJson(index[k])},
                      {"view", VecJson(view[k])},
                      {"address", VecJson(IndexDirection(pairs[k], brdf.reparam()))},
                      // Where the address looks in the source map (before the job's rotation).
                      {"map_direction",
                       VecJson(rotation.Transposed() * IndexDirection(pairs[k], brdf.reparam()))},
                      {"grazing", pairs[k].grazing},
                      {"shrm", RgbJson(got[k])},
                      {"reference", RgbJson(ref[k])},
                      {"error", PairError(got[k], ref[k], floor)}});
  }
  out["pairs"] = {{"seed", "verify"},
                  {"count", pairs.size()},
                  {"floor", RgbJson(floor)},
                  {"front", {{"rms", stats.front.rms}, {"max", stats.front.max}}},
                  {"grazing", {{"rms", stats.grazing.rms}, {"max", stats.grazing.max}}},
                  {"negative", stats.negative},
                  {"points", points}};

  // Spheres: the SHRM at every pixel, the brute-force sum at the cell centres.
  const int size = kSpherePixels, cells = kReferenceCells;
  const Image shrm = RenderShrmSpheres(cube, size, &brdf, threads);
  const double exposure = MidGreyExposure(shrm);
  const auto views = SphereViews();
  std::vector<Vec3> cell_index, cell_view;
  std::vector<std::array<int, 3>> cell_at;  // view, cx, cy
  for (int s = 0; s < kSphereViews; ++s) {
    const Frame f = ViewFrame(views[s].view);
    for (int cy = 0; cy < cells; ++cy)
      for (int cx = 0; cx < cells; ++cx) {
        const std::optional<Vec3> n =
            SphereNormal(f, 2 * (cx + 0.5) / cells - 1, 1 - 2 * (cy + 0.5) / cells);
        if (!n) continue;
        cell_index.push_back(IndexAt(cube, *n));
        cell_view.push_back(f.view);
        cell_at.push_back({s, cx, cy});
      }
  }
  const std::vector<Rgb> cell_ref = reference.RadianceMany(brdf, rotation, cell_index, cell_view,
                                                           threads, kCheckReferenceTolerance);
  Image ref_img = BlankImage(kSphereViews * size, size, 3);
  Image err_img = BlankImage(kSphereViews * size, size, 3);
  const int cell_px = size / cells;
  std::vector<nlohmann::json> samples(kSphereViews, nlohmann::json::array());
  // Per view, front (N.V >= kGrazingCosine) and grazing cells apart, as the job's check.
  struct Stats {
    double sum_sq = 0, largest = 0;
    int count = 0;
    void Add(double e) { sum_sq += e * e, largest = std::max(largest, e), ++count; }
    nlohmann::json Json() const {
      return {
          {"cells", count}, {"rms", count > 0 ? std::sqrt(sum_sq / count) : 0.0}, {"max", largest}};
    }
  };
  std::vector<Stats> front(kSphereViews), grazing(kSphereViews);
  for (size_t k = 0; k < cell_at.size(); ++k) {
    const auto [s, cx, cy] = cell_at[k];
    const Rgb got_k = ShrmEvalWithLights(cube, brdf, cell_index[k], cell_view[k]);
    const double e = PairError(got_k, cell_ref[k], floor);
    const Vec3 normal = cube.index == ReparamKind::kTangent ? cell_view[k] : cell_index[k];
    (normal.Dot(cell_view[k]) >= kGrazingCosine ? front : grazing)[s].Add(e);
    const std::array<uint8_t, 3> colour = ErrorColour(ErrorScalePosition(e));
    for (int y = cy * cell_px; y < (cy + 1) * cell_px; ++y)
      for (int x = cx * cell_px; x < (cx + 1) * cell_px; ++x) {
        const size_t o = (static_cast<size_t>(y) * ref_img.width + s * size + x) * 3;
        for (int c = 0; c < 3; ++c) {
          ref_img.pixels[o + c] = static_cast<float>(cell_ref[k][c]);
          err_img.pixels[o + c] = colour[c] / 255.0f;
        }
      }
    samples[s].push_back({{"pixel", {(cx + 0.5) * cell_px, (cy + 0.5) * cell_px}},
                          {"index", VecJson(cell_index[k])},
                          {"view", VecJson(cell_view[k])},
                          {"shrm", RgbJson(got_k)},
                          {"reference", RgbJson(cell_ref[k])},
                          {"error", e}});
  }
  SHRM_ASSIGN_OR_RETURN(std::string shrm_png,
                        PngBase64(WithDiscAlpha(TonemapPreview(shrm, exposure), size)));
  SHRM_ASSIGN_OR_RETURN(std::string ref_png,
                        PngBase64(WithDiscAlpha(TonemapPreview(ref_img, exposure), size)));
  SHRM_ASSIGN_OR_RETURN(std::string err_png, PngBase64(WithDiscAlpha(err_img, size)));
  const Image small = RenderShrmSpheres(cube, kThumbnailSpherePixels, &brdf, threads);
  SHRM_ASSIGN_OR_RETURN(
      std::string thumb_png,
      PngBase64(WithDiscAlpha(TonemapPreview(small, exposure), kThumbnailSpherePixels)));
  nlohmann::json view_list = nlohmann::json::array();
  for (int s = 0; s < kSphereViews; ++s) {
    view_list.push_back({{"name", views[s].name},
                         {"view", VecJson(views[s].view)},
                         {"front", front[s].Json()},
                         {"grazing", grazing[s].Json()},
                         {"samples", samples[s]}});
  }
  out["spheres"] = {{"size", size},
                    {"cells", cells},
                    {"exposure", exposure},
                    {"shrm_png", shrm_png},
                    {"reference_png", ref_png},
                    {"error_png", err_png},
                    {"thumbnail_png", thumb_png},
                    {"views", view_list}};
  out["reference"] = {{"method", "FastReference"}, {"relative_tolerance", kFastReferenceTolerance}};
  out["error_scale"] = {{"log10_low", kErrorScaleLow}, {"log10_high", kErrorScaleHigh}};
  return out;
}

}  // namespace shrm::jobs
