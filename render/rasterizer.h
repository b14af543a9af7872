// A small z-buffer rasterizer for looking at meshes: orthographic, one sample per pixel centre,
// headlight Lambert shading, deterministic (the same triangles in the same order give the same
// bytes). Its job is honest shading, not realism: a face seen from behind (through a hole or an
// open boundary) is drawn in a separate, darker colour, so inverted normals and holes show.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh_sink.h"
#include "render/camera.h"

namespace isoslab::render {

using Rgb = std::array<std::uint8_t, 3>;

struct Style {
  /// Gouraud shading from the vertex normals when given; else every face flat.
  bool smooth = false;
  Rgb background{255, 255, 255};
  /// The front faces' colour; a face seen from behind is drawn in `backColour`.
  Rgb colour{230, 218, 196};
  Rgb backColour{110, 120, 160};
  double ambient = 0.2;
};

/// The palette for colouring parts (chunks) of a mesh: distinct hues, cycled.
Rgb partColour(std::size_t part);

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // row-major, top row first, 3 bytes per pixel
  Rgb pixel(int x, int y) const {
    const std::size_t at =
        3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
    return {rgb[at], rgb[at + 1], rgb[at + 2]};
  }
};

class Rasterizer {
 public:
  Rasterizer(const Camera& camera, const Style& style);

  /// Draws one triangle, counter-clockwise seen from its front (isoslab's winding: the side of
  /// lower values). `normals` are its vertices' unit normals, or null for flat shading; `colour`
  /// replaces the style's front colour when given.
  void draw(const std::array<Vec3f, 3>& corners, const std::array<Vec3f, 3>* normals, const Rgb* colour = nullptr);

  /// The image so far.
  Image image() const;
  /// Pixels covered by at least one triangle.
  std::int64_t coveredPixels() const noexcept { return covered_; }
  const Style& style() const noexcept { return style_; }
  const Camera& camera() const noexcept { return camera_; }

 private:
  Camera camera_;
  Style style_;
  std::vector<float> depth_;
  std::vector<std::uint8_t> rgb_;
  std::int64_t covered_ = 0;
};

/// Streams a mesh into a Rasterizer: the MeshSink of `extract --preview` and of `render`. Keeps
/// only the image and the two chunks' vertices that the contract lets triangles reference.
class RenderSink final : public MeshSink {
 public:
  /// The camera is fitted to the header's volume bounds in begin().
  RenderSink(const View& view, int width, int height, const Style& style);
  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override {}
  Image image() const;

 private:
  View view_;
  int width_;
  int height_;
  Style style_;
  std::optional<Rasterizer> raster_;
  VertexWindow window_;
  bool normals_ = false;
};

/// Whether a mesh space name is RAS (the camera's patient directions; every other space is LPS).
bool isRas(const std::string& space);

}  // namespace isoslab::render
