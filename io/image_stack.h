// Stacks of 2-D images read through OpenImageIO, one image (or TIFF page) per slice: a folder of
// images, a glob ("slices/*.png") or printf pattern ("img%03d.tif") in natural numeric order, a
// list of files, or one multi-page TIFF.
//
// Pixels keep their stored values (8/16/32-bit integers and floats, not normalised). Palette
// images arrive through their colour map; colour images become luminance (Rec. 709 weights; a
// grey pixel keeps its value exactly) unless a channel is chosen. Spacing comes from --spacing,
// else from the files' resolution tags when they hold one (x and y), else 1; the note says which.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

struct ImageStackOptions {
  int channel = -1;
  std::optional<std::array<double, 3>> spacing;
};

/// True if `path` names an image file OpenImageIO reads (by extension).
bool isImageFile(const std::string& path);

/// True if `inputs` look like an image stack: image files, a folder whose files are images, or a
/// glob or printf pattern of image file names.
bool isImageStack(const std::vector<std::string>& inputs);

/// Opens the stack; notes (spacing source, slice count) are appended to `notes`. Throws
/// isoslab::Error naming the file and the problem.
std::unique_ptr<SliceSource> openImageStack(const std::vector<std::string>& inputs, const ImageStackOptions& options,
                                            std::vector<std::string>* notes);

}  // namespace isoslab
