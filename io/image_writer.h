// Images out: 8-bit RGB pixels to a PNG file (libpng), with optional text labels.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace isoslab {

/// Text drawn onto an image: its baseline starts at (x, y) pixels, in black, DejaVu Sans.
struct ImageLabel {
  int x = 0;
  int y = 0;
  std::string text;
  int size = 16;
};

/// Writes `rgb` (row-major, top row first, 3 bytes per pixel) as a PNG at `path`, complete or not
/// at all (AtomicFile). Throws isoslab::Error naming the file.
/// `labels` are drawn first (FreeType through the OpenImageIO module, loaded only then; the font is
/// Debian's fonts-dejavu-core).
void writePng(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb,
              const std::vector<ImageLabel>& labels = {});

}  // namespace isoslab
