// Images out: 8-bit RGB pixels to a PNG file (through the OpenImageIO module).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace isoslab {

/// Writes `rgb` (row-major, top row first, 3 bytes per pixel) as a PNG at `path`, complete or not
/// at all (AtomicFile). Throws isoslab::Error naming the file.
void writePng(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb);

}  // namespace isoslab
