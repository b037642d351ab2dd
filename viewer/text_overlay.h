// The viewer's in-frame text overlay, GL-free part: a built-in 5x7 bitmap font (printable ASCII
// 32-126, no font files) and a CPU rasterizer turning lines of text into an RGBA8 image (white
// text with a 1-pixel dark outline on a translucent dark box, scaled by an integer factor). The
// GL part (texture, blended screen-space quad in the top-left corner) is viewer/overlay_gl.h.
#ifndef SHRM_VIEWER_TEXT_OVERLAY_H_
#define SHRM_VIEWER_TEXT_OVERLAY_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace shrm::viewer {

// Glyph metrics in font pixels (before the scale): a glyph is kGlyphWidth x kGlyphHeight; a
// character cell adds one column and two rows of spacing; the box has kOverlayPadding pixels
// around the text.
inline constexpr int kGlyphWidth = 5;
inline constexpr int kGlyphHeight = 7;
inline constexpr int kCellWidth = kGlyphWidth + 1;
inline constexpr int kCellHeight = kGlyphHeight + 2;
inline constexpr int kOverlayPadding = 2;

// Rows of a glyph from the top; bit 4 is the leftmost column, bit 0 the rightmost.
using Glyph = std::array<uint8_t, kGlyphHeight>;

// Whether `c` is in the font (printable ASCII 32-126).
bool HasGlyph(char c);
// The glyph of `c`; characters outside the font are drawn as '?'.
const Glyph& GlyphOf(char c);

// An RGBA8 image, straight (not premultiplied) alpha, rows from the top.
struct OverlayImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgba;  // width * height * 4

  const uint8_t* at(int x, int y) const { return &rgba[(static_cast<size_t>(y) * width + x) * 4]; }
};

// Size of the rasterized lines: (2 kOverlayPadding + longest line x kCellWidth) x scale by
// (2 kOverlayPadding + lines x kCellHeight) x scale; 0 x 0 without lines.
void OverlaySize(const std::vector<std::string>& lines, int scale, int* width, int* height);

// The lines, one per row of cells, top-left aligned: text pixels white (255, 255, 255, 255),
// their 8-neighbours outside the text black (0, 0, 0, 255), the rest of the box (0, 0, 0, 144).
// Glyph pixel (gx, gy) of character i of line j covers the scale x scale block at
// ((kOverlayPadding + i kCellWidth + gx) scale, (kOverlayPadding + j kCellHeight + gy) scale).
// scale < 1 counts as 1.
OverlayImage RasterizeOverlay(const std::vector<std::string>& lines, int scale);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_TEXT_OVERLAY_H_
