// The viewer's in-frame text overlay without GL (viewer/text_overlay.h): the built-in font covers
// printable ASCII, letters and digits are distinct, and the rasterizer's size and pixel layout.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "viewer/text_overlay.h"

namespace shrm::viewer {
namespace {

bool Blank(const Glyph& g) {
  for (uint8_t row : g)
    if (row != 0) return false;
  return true;
}

TEST(ViewerOverlayTest, EveryPrintableCharacterHasAGlyph) {
  for (int c = 32; c <= 126; ++c) {
    EXPECT_TRUE(HasGlyph(static_cast<char>(c))) << c;
    for (uint8_t row : GlyphOf(static_cast<char>(c))) EXPECT_EQ(row & ~0x1F, 0) << c;
    if (c != ' ') {
      EXPECT_FALSE(Blank(GlyphOf(static_cast<char>(c)))) << "'" << char(c) << "'";
    }
  }
  EXPECT_TRUE(Blank(GlyphOf(' ')));
  EXPECT_FALSE(HasGlyph('\n'));
  EXPECT_FALSE(HasGlyph(static_cast<char>(127)));
  EXPECT_EQ(GlyphOf('\t'), GlyphOf('?'));  // outside the font: '?'
}

TEST(ViewerOverlayTest, DigitsAndLettersAreDistinct) {
  std::string chars;
  for (char c = '0'; c <= '9'; ++c) chars += c;
  for (char c = 'A'; c <= 'Z'; ++c) chars += c;
  for (char c = 'a'; c <= 'z'; ++c) chars += c;
  std::set<Glyph> seen;
  for (char c : chars) EXPECT_TRUE(seen.insert(GlyphOf(c)).second) << "'" << c << "' repeats";
  // The overlay's punctuation is distinct from them and from each other.
  for (char c : std::string(".,:=()/-+%_[]")) {
    EXPECT_TRUE(seen.insert(GlyphOf(c)).second) << "'" << c << "' repeats";
  }
}

TEST(ViewerOverlayTest, SizeIsLinesTimesCellsTimesScale) {
  const std::vector<std::string> lines = {"mode 1 global-shrm", "F_B 6 P_B 4", ""};
  for (int scale : {1, 2, 3}) {
    const OverlayImage img = RasterizeOverlay(lines, scale);
    EXPECT_EQ(img.width, (2 * kOverlayPadding + 18 * kCellWidth) * scale);
    EXPECT_EQ(img.height, (2 * kOverlayPadding + 3 * kCellHeight) * scale);
    EXPECT_EQ(img.rgba.size(), static_cast<size_t>(img.width) * img.height * 4);
    int w = 0, h = 0;
    OverlaySize(lines, scale, &w, &h);
    EXPECT_EQ(w, img.width);
    EXPECT_EQ(h, img.height);
  }
  const OverlayImage none = RasterizeOverlay({}, 2);
  EXPECT_EQ(none.width, 0);
  EXPECT_EQ(none.height, 0);
  EXPECT_TRUE(none.rgba.empty());
}

// "1" (rows .#... ##... .#... .#... .#... .#... ###.. from bit 4) at scale 2 in the second line.
TEST(ViewerOverlayTest, TextPixelsWhereExpected) {
  constexpr int kScale = 2;
  const OverlayImage img = RasterizeOverlay({"x", "a1"}, kScale);
  const char* kOne[kGlyphHeight] = {"..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."};
  const int x0 = kOverlayPadding + 1 * kCellWidth, y0 = kOverlayPadding + 1 * kCellHeight;
  for (int gy = 0; gy < kGlyphHeight; ++gy)
    for (int gx = 0; gx < kGlyphWidth; ++gx)
      for (int sy = 0; sy < kScale; ++sy)
        for (int sx = 0; sx < kScale; ++sx) {
          const uint8_t* p = img.at((x0 + gx) * kScale + sx, (y0 + gy) * kScale + sy);
          const bool text = kOne[gy][gx] == '#';
          EXPECT_EQ(p[0], text ? 255 : 0) << gx << "," << gy;
          if (text) {
            EXPECT_EQ(p[3], 255) << gx << "," << gy;
          }
        }
  // The outline: left of the bottom row ".###." and right of the flag's top, dark and opaque.
  for (const auto& [gx, gy] : {std::pair{0, 6}, std::pair{4, 6}, std::pair{3, 0}}) {
    const uint8_t* p = img.at((x0 + gx) * kScale, (y0 + gy) * kScale);
    EXPECT_EQ(p[0], 0) << gx << "," << gy;
    EXPECT_EQ(p[3], 255) << gx << "," << gy;
  }
  // Far from any text: the translucent box (the corner; line 0 "x" is one character long, so
  // the second cell of line 0 is empty).
  for (const auto& [x, y] : {std::pair{0, 0}, std::pair{x0 + 3, kOverlayPadding + 3}}) {
    const uint8_t* p = img.at(x * kScale, y * kScale);
    EXPECT_EQ(p[0], 0) << x << "," << y;
    EXPECT_EQ(p[3], 144) << x << "," << y;
  }
}

}  // namespace
}  // namespace shrm::viewer
