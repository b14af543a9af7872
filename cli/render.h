// `isoslab render MESH -o view.png` and `extract --preview view.png`: images of meshes.
#pragma once

#include <CLI/CLI.hpp>

#include <memory>
#include <optional>
#include <string>

#include "render/rasterizer.h"

namespace isoslab::cli {

/// What the image looks like, shared by render and --preview.
struct ImageArgs {
  std::string view = "front";
  std::optional<double> azimuth;
  std::optional<double> elevation;
  std::string size = "800";
  std::string background = "white";
  std::string shading = "auto";  // auto: smooth when the mesh has normals
  bool chunkColours = false;
};

/// Adds --view, --azimuth, --elevation, --size, --background and --shading (with `prefix`, e.g.
/// "preview-", for extract).
void addImageOptions(CLI::App* cmd, ImageArgs& args, const std::string& prefix, const std::string& group);

/// The camera view, image size and style the options ask for; `hasNormals` for --shading auto.
render::View viewOf(const ImageArgs& args);
std::array<int, 2> sizeOf(const ImageArgs& args);
render::Style styleOf(const ImageArgs& args, bool hasNormals);

int runRender(const std::string& input, const std::string& output, const ImageArgs& args);

}  // namespace isoslab::cli
