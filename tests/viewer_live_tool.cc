// Helper of tests/viewer_live_test.sh (the viewer's live mode against the offline path):
//   viewer_live_tool downsample IN OUT WIDTH
//       a lat-long EXR box-filtered to WIDTH x WIDTH/2 (viewer's DownsampleLatLong), so that each
//       live test takes seconds;
//   viewer_live_tool compare A B TOL [nonzero|zero MASK]
//       per pixel |A - B| (RGB norm) / max(|B|, 1e-6 + 1e-3 mean |B|) over the pixels where MASK
//       (an EXR screenshot) is nonzero (the mesh: a screenshot without --env has a zero
//       background) or zero (the background); all pixels without a mask. Prints the pixel count
//       and the largest and RMS relative difference; exit 0 if the largest <= TOL and the pixels
//       are at least 10% of the image, 1 otherwise (2: usage, unreadable files).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/io/image.h"
#include "viewer/scene_source.h"

namespace {

int Usage() {
  std::fprintf(stderr,
               "usage: viewer_live_tool downsample IN OUT WIDTH\n"
               "       viewer_live_tool compare A B TOL [nonzero|zero MASK]\n");
  return 2;
}

bool NonZero(const shrm::Image& img, size_t pixel) {
  for (int c = 0; c < 3; ++c)
    if (img.pixels[3 * pixel + c] != 0.0f) return true;
  return false;
}

double Norm(const shrm::Image& img, size_t pixel) {
  double s = 0;
  for (int c = 0; c < 3; ++c)
    s += static_cast<double>(img.pixels[3 * pixel + c]) * img.pixels[3 * pixel + c];
  return std::sqrt(s);
}

int Downsample(const std::string& in, const std::string& out, int width) {
  absl::StatusOr<shrm::Image> img = shrm::ReadImageRgb(in);
  if (!img.ok()) {
    std::fprintf(stderr, "%s\n", std::string(img.status().message()).c_str());
    return 2;
  }
  absl::StatusOr<shrm::Image> small = shrm::viewer::DownsampleLatLong(*img, width);
  absl::Status s = small.ok() ? shrm::WriteExr(out, *small) : small.status();
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", std::string(s.message()).c_str());
    return 2;
  }
  return 0;
}

int Compare(const std::string& a_path, const std::string& b_path, double tol,
            const std::string& mask_kind, const std::string& mask_path) {
  absl::StatusOr<shrm::Image> a = shrm::ReadImageRgb(a_path), b = shrm::ReadImageRgb(b_path);
  absl::StatusOr<shrm::Image> mask = mask_path.empty() ? b : shrm::ReadImageRgb(mask_path);
  for (const auto* r : {&a, &b, &mask}) {
    if (!r->ok()) {
      std::fprintf(stderr, "%s\n", std::string(r->status().message()).c_str());
      return 2;
    }
  }
  if (a->width != b->width || a->height != b->height || mask->width != a->width ||
      mask->height != a->height) {
    std::fprintf(stderr, "the images differ in size\n");
    return 1;
  }
  const size_t n = static_cast<size_t>(a->width) * a->height;
  double mean = 0;
  for (size_t i = 0; i < n; ++i) mean += Norm(*b, i) / n;
  size_t count = 0;
  double largest = 0, sum2 = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!mask_kind.empty() && NonZero(*mask, i) != (mask_kind == "nonzero")) continue;
    double d = 0;
    for (int c = 0; c < 3; ++c) {
      const double e = static_cast<double>(a->pixels[3 * i + c]) - b->pixels[3 * i + c];
      d += e * e;
    }
    const double rel = std::sqrt(d) / std::max(Norm(*b, i), 1e-6 + 1e-3 * mean);
    largest = std::max(largest, rel);
    sum2 += rel * rel;
    ++count;
  }
  std::printf("%zu of %zu pixels, largest relative difference %.3g, RMS %.3g\n", count, n, largest,
              count > 0 ? std::sqrt(sum2 / count) : 0.0);
  return count * 10 >= n && largest <= tol ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return Usage();
  const std::string cmd = argv[1];
  if (cmd == "downsample" && argc == 5) return Downsample(argv[2], argv[3], std::atoi(argv[4]));
  if (cmd == "compare" && (argc == 5 || argc == 7)) {
    const std::string kind = argc == 7 ? argv[5] : "";
    if (!kind.empty() && kind != "nonzero" && kind != "zero") return Usage();
    return Compare(argv[2], argv[3], std::atof(argv[4]), kind, argc == 7 ? argv[6] : "");
  }
  return Usage();
}
