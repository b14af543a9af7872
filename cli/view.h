// `isoslab view OUT.glb`: a self-contained HTML viewer page written next to the mesh.
#pragma once

#include <string>

namespace isoslab::cli {

/// Writes the viewer page for `glb` (and the report `report`, when not empty) to `page` (empty:
/// the .glb's path with .html), and prints how to open it. Returns the exit status.
int runView(const std::string& glb, const std::string& report, const std::string& page);

}  // namespace isoslab::cli
