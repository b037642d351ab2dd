// Test fixtures shared by the tests on the bundled real HDR maps: a map box-downsampled to a
// small lat-long grid (keeps tests fast), and its pixels as radiance samples with the Fejer-1
// solid angles the transform integrates with (independent of core/envmap).
#ifndef SHRM_TESTS_TEST_MAPS_H_
#define SHRM_TESTS_TEST_MAPS_H_

#include <random>
#include <string>
#include <vector>

#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "core/transform/sht.h"
#include "gtest/gtest.h"

namespace shrm::testing {

// data/envmaps/<name> (1024 x 512) box-filtered to width x width / 2 (width divides 1024).
inline Image LoadBundledMap(const std::string& name, int width) {
  auto full = ReadImageRgb(std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name);
  EXPECT_TRUE(full.ok()) << full.status();
  Image out;
  out.width = width;
  out.height = width / 2;
  out.channels = 3;
  out.pixels.assign(static_cast<size_t>(out.width) * out.height * 3, 0.0f);
  const int fx = full->width / out.width, fy = full->height / out.height;
  for (int y = 0; y < full->height; ++y)
    for (int x = 0; x < full->width; ++x)
      for (int c = 0; c < 3; ++c)
        out.pixels[((y / fy) * out.width + x / fx) * 3 + c] += full->at(x, y, c) / (fx * fy);
  return out;
}

// One sample per pixel of a lat-long image: direction, Fejer-1 weight x 2 pi / W, RGB.
inline std::vector<EnvSample> LatLongSamples(const Image& img) {
  const ShtGrid grid{img.width, img.height, ShtGridKind::kEquiangular};
  const RingQuadrature q = FejerFirstRule(img.height);
  std::vector<EnvSample> samples;
  for (int j = 0; j < img.height; ++j)
    for (int i = 0; i < img.width; ++i) {
      EnvSample e;
      e.dir = ShtGridDirection(grid, i, j);
      e.solid_angle = q.weight[j] * 2 * kPi / img.width;
      for (int c = 0; c < 3; ++c) e.rgb[c] = img.at(i, j, c);
      samples.push_back(e);
    }
  return samples;
}

// A band-limited lat-long map: random RGB SH coefficients of degree `lmax` (normal, sigma 0.3,
// from `seed`) plus 4 on the constant term (mostly positive radiance), synthesized at the pixel
// centres of a width x height grid. Its coefficients to any degree < height are exact under the
// transform's Fejer rule and vanish above lmax.
inline Image BandLimitedLatLong(int lmax, unsigned seed, int width, int height) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, 0.3);
  std::vector<double> c(ShCount(lmax) * 3);
  for (double& x : c) x = gauss(rng);
  for (int ch = 0; ch < 3; ++ch) c[ch] += 4.0;
  Image img;
  img.width = width;
  img.height = height;
  img.channels = 3;
  img.pixels.resize(static_cast<size_t>(img.width) * img.height * 3);
  const ShtGrid grid{img.width, img.height, ShtGridKind::kEquiangular};
  std::vector<double> y(ShCount(lmax));
  for (int j = 0; j < img.height; ++j)
    for (int i = 0; i < img.width; ++i) {
      EvalSh(lmax, ShFrameFromWorld(ShtGridDirection(grid, i, j)), y);
      for (int ch = 0; ch < 3; ++ch) {
        double v = 0;
        for (int k = 0; k < ShCount(lmax); ++k) v += c[3 * k + ch] * y[k];
        img.pixels[(static_cast<size_t>(j) * img.width + i) * 3 + ch] = static_cast<float>(v);
      }
    }
  return img;
}

}  // namespace shrm::testing

#endif  // SHRM_TESTS_TEST_MAPS_H_
