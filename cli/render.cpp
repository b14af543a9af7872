#include "cli/render.h"

#include <fmt/format.h>

#include <cmath>

#include "cli/arguments.h"
#include "core/interrupt.h"
#include "encode/mesh_metadata.h"
#include "encode/mesh_reader.h"
#include "io/image_writer.h"

namespace isoslab::cli {
namespace {

constexpr int kMaxImageSide = 16384;

std::optional<std::array<int, 2>> parseSize(const std::string& text) {
  const std::size_t x = text.find('x');
  const std::string w = text.substr(0, x);
  const std::string h = x == std::string::npos ? w : text.substr(x + 1);
  auto number = [](const std::string& s) -> int {
    if (s.empty() || s.size() > 6 || s.find_first_not_of("0123456789") != std::string::npos) return 0;
    return std::stoi(s);
  };
  const int width = number(w);
  const int height = number(h);
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) return std::nullopt;
  return std::array<int, 2>{width, height};
}

std::optional<render::Rgb> parseColour(const std::string& text) {
  if (text == "white") return render::Rgb{255, 255, 255};
  if (text == "black") return render::Rgb{0, 0, 0};
  if (text == "grey" || text == "gray") return render::Rgb{128, 128, 128};
  if (text.size() != 7 || text[0] != '#' || text.find_first_not_of("0123456789abcdefABCDEF", 1) != std::string::npos)
    return std::nullopt;
  render::Rgb c{};
  for (std::size_t k = 0; k < 3; ++k)
    c[k] = static_cast<std::uint8_t>(std::stoi(text.substr(1 + 2 * k, 2), nullptr, 16));
  return c;
}

// Area-weighted vertex normals, for smooth shading of a mesh whose file has none (STL).
std::vector<Vec3f> vertexNormals(const IndexedMesh& mesh) {
  std::vector<Vec3d> sum(mesh.positions.size(), Vec3d{0, 0, 0});
  for (std::size_t face = 0; face < mesh.triangles.size(); ++face) {
    throwIfInterruptedEvery(face);
    const Triangle& t = mesh.triangles[face];
    const Vec3f& a = mesh.positions[t[0]];
    const Vec3f& b = mesh.positions[t[1]];
    const Vec3f& c = mesh.positions[t[2]];
    const Vec3d n = cross(Vec3d{b.x - a.x, b.y - a.y, b.z - a.z}, Vec3d{c.x - a.x, c.y - a.y, c.z - a.z});
    for (VertexId v : t) {
      for (std::size_t k = 0; k < 3; ++k) sum[v][k] += n[k];
    }
  }
  std::vector<Vec3f> normals;
  normals.reserve(sum.size());
  for (const Vec3d& n : sum) {
    const double length = norm(n);
    const double s = length > 0 ? 1 / length : 0;
    normals.push_back({static_cast<float>(n[0] * s), static_cast<float>(n[1] * s), static_cast<float>(n[2] * s)});
  }
  return normals;
}

}  // namespace

void addImageOptions(CLI::App* cmd, ImageArgs& args, const std::string& prefix, const std::string& group) {
  const std::string views = alternatives(render::presetNames());
  cmd->add_option("--" + prefix + "view", args.view,
                  "View: " + views + " (front is anterior for patient meshes; the patient's left on the right)")
      ->transform(oneOf("view", render::presetNames()))
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--" + prefix + "azimuth", args.azimuth,
                  "Degrees about the superior axis from the view (90: from the patient's left)")
      ->check(finiteNumber())
      ->group(group);
  cmd->add_option("--" + prefix + "elevation", args.elevation, "Degrees up from the view, -90 .. 90")
      ->check(CLI::Range(-90.0, 90.0))
      ->group(group);
  cmd->add_option("--" + prefix + "size", args.size, "Image size in pixels: N (square) or WxH, at most 16384")
      ->check(CLI::Validator(
          [](std::string& v) { return parseSize(v) ? std::string() : fmt::format("'{}' is not N or WxH pixels", v); },
          ""))
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--" + prefix + "background", args.background, "Background: white, black, grey or #rrggbb")
      ->check(CLI::Validator(
          [](std::string& v) {
            return parseColour(v) ? std::string() : fmt::format("'{}' is not white, black, grey or #rrggbb", v);
          },
          ""))
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--" + prefix + "shading", args.shading,
                  "flat, smooth (from the vertex normals) or auto (smooth when the mesh has normals)")
      ->transform(oneOf("shading", {"auto", "flat", "smooth"}))
      ->capture_default_str()
      ->group(group);
}

render::View viewOf(const ImageArgs& args) {
  render::View view = render::presetView(args.view).value_or(render::View{});
  if (args.azimuth) view.azimuth += *args.azimuth;
  if (args.elevation) view.elevation = *args.elevation;
  return view;
}

std::array<int, 2> sizeOf(const ImageArgs& args) {
  return parseSize(args.size).value_or(std::array<int, 2>{800, 800});
}

render::Style styleOf(const ImageArgs& args, bool hasNormals) {
  render::Style style;
  style.smooth = args.shading == "smooth" || (args.shading == "auto" && hasNormals);
  style.background = parseColour(args.background).value_or(style.background);
  return style;
}

int runRender(const std::string& input, const std::string& output, const ImageArgs& args) {
  MeshMetadata meta;
  IndexedMesh mesh = readMesh(input, &meta);
  const MeshHeader header = headerForDecodedMesh(meta, mesh.positions, !mesh.normals.empty());
  const render::Style style = styleOf(args, !mesh.normals.empty());
  if (style.smooth && mesh.normals.empty()) mesh.normals = vertexNormals(mesh);
  const auto [width, height] = sizeOf(args);
  render::Rasterizer raster(
      render::Camera::fit(header.volumeBounds, viewOf(args), render::isRas(header.space), width, height), style);
  std::size_t part = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    throwIfInterruptedEvery(t);
    while (part < mesh.partEnds.size() && t >= mesh.partEnds[part]) ++part;
    const Triangle& tri = mesh.triangles[t];
    const std::array<Vec3f, 3> corners{mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]};
    const render::Rgb colour = render::partColour(part);
    const render::Rgb* tint = args.chunkColours && !mesh.partEnds.empty() ? &colour : nullptr;
    if (style.smooth) {
      const std::array<Vec3f, 3> normals{mesh.normals[tri[0]], mesh.normals[tri[1]], mesh.normals[tri[2]]};
      raster.draw(corners, &normals, tint);
    } else {
      raster.draw(corners, nullptr, tint);
    }
  }
  const render::Image image = raster.image();
  writePng(output, image.width, image.height, image.rgb);
  std::fprintf(stderr, "isoslab: %zu triangles, %dx%d pixels -> %s\n", mesh.triangles.size(), width, height,
               output.c_str());
  return 0;
}

}  // namespace isoslab::cli
