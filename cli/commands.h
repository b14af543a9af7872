// The commands other than extract, compare, render, view and batch: info, metrics, decode and
// phantom. Each prints its own lines; errors are thrown (isoslab::Error, UsageError).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "cli/source_options.h"

namespace isoslab::cli {

/// `isoslab info`: a volume's geometry and value range (with `histogramBins`, its histogram and
/// Otsu's split); DICOM inputs list every series.
int runInfo(const std::vector<std::string>& inputs, const RawArgs& raw, std::size_t histogramBins);
/// `isoslab metrics`: a mesh file's statistics as JSON, on stdout or to `reportPath`.
int runMetrics(const std::string& input, const std::string& sphereText, const std::string& reportPath);
/// `isoslab decode`: a .glb or .drc to .ply, .stl or .obj.
int runDecode(const std::string& input, const std::string& output);
/// `isoslab phantom`: a phantom spec to a volume file.
int runPhantom(const std::string& spec, const std::string& output, bool compress);

}  // namespace isoslab::cli
