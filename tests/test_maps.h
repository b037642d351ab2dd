// Test fixtures shared by the tests on the bundled real HDR maps: a map box-downsampled to a
// small lat-long grid (keeps tests fast), and its pixels as radiance samples with the Fejer-1
// solid angles the transform integrates with (independent of core/envmap).
#ifndef SHRM_TESTS_TEST_MAPS_H_
#define SHRM_TESTS_TEST_MAPS_H_

#include <string>
#include <vector>

#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/sh/quadrature.h"
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

}  // namespace shrm::testing

#endif  // SHRM_TESTS_TEST_MAPS_H_
