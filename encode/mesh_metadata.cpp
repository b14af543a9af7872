#include "encode/mesh_metadata.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace isoslab {

std::string spaceTag(const std::string& space) {
  if (space == "lps") return "LPS";
  if (space == "ras") return "RAS";
  return "";
}

std::vector<std::string> metadataLines(const MeshHeader& h) {
  std::vector<std::string> lines;
  lines.push_back(fmt::format("isoslab {} iso {} space {}", h.method, h.iso, h.space));
  const std::string tag = spaceTag(h.space);
  if (!tag.empty()) lines.push_back("SPACE=" + tag);
  if (h.volumeFaces) {
    const auto& b = h.volumeBounds;
    lines.push_back(fmt::format("volume_bounds {} {} {} {} {} {}", b[0], b[1], b[2], b[3], b[4], b[5]));
    std::string faces = "volume_faces";
    for (const FacePlane& f : *h.volumeFaces) faces += fmt::format(" {} {} {} {}", f[0], f[1], f[2], f[3]);
    lines.push_back(faces);
    if (h.positionTolerance > 0) lines.push_back(fmt::format("position_tolerance {}", h.positionTolerance));
  }
  return lines;
}

void parseMetadataLine(const std::string& line, MeshMetadata& meta) {
  std::istringstream s(line);
  std::string word;
  s >> word;
  if (word == "isoslab") {
    std::string method, isoWord, spaceWord, space;
    double iso = 0;
    if (s >> method >> isoWord >> iso && isoWord == "iso" && std::isfinite(iso)) {
      meta.method = method;
      meta.iso = iso;
      if (s >> spaceWord >> space && spaceWord == "space") meta.space = space;
    }
  } else if (word == "volume_bounds") {
    std::array<double, 6> b{};
    for (double& v : b) {
      if (!(s >> v) || !std::isfinite(v)) return;
    }
    meta.volumeBounds = b;
  } else if (word == "position_tolerance") {
    double t = 0;
    if (s >> t && std::isfinite(t) && t >= 0) meta.positionTolerance = t;
  } else if (word == "volume_faces") {
    VolumeFaces faces{};
    for (FacePlane& f : faces) {
      for (double& v : f) {
        if (!(s >> v) || !std::isfinite(v)) return;
      }
    }
    meta.volumeFaces = faces;
  }
}

MeshHeader headerFromMetadata(const MeshMetadata& meta) {
  MeshHeader h;
  h.method = meta.method.empty() ? "decoded" : meta.method;
  h.iso = meta.iso.value_or(0.0);
  h.space = meta.space;
  if (meta.volumeBounds && meta.volumeFaces) {
    h.volumeBounds = *meta.volumeBounds;
    h.volumeFaces = meta.volumeFaces;
    h.positionTolerance = meta.positionTolerance;
  }
  return h;
}

MeshHeader headerForDecodedMesh(const MeshMetadata& meta, const std::vector<Vec3f>& positions, bool normals) {
  MeshHeader header = headerFromMetadata(meta);
  header.normals = normals;
  if (!header.volumeFaces && !positions.empty()) {
    // Unknown volume: the mesh's own box, for a Draco grid.
    std::array<double, 6> b{};
    for (std::size_t a = 0; a < 3; ++a) {
      b[a] = std::numeric_limits<double>::infinity();
      b[a + 3] = -std::numeric_limits<double>::infinity();
    }
    for (const Vec3f& p : positions) {
      const double c[3] = {p.x, p.y, p.z};
      for (std::size_t a = 0; a < 3; ++a) {
        b[a] = std::min(b[a], c[a]);
        b[a + 3] = std::max(b[a + 3], c[a]);
      }
    }
    header.volumeBounds = b;
  }
  return header;
}

std::vector<std::uint8_t> volumeFaceFlags(const std::vector<Vec3f>& positions, const VolumeFaces& faces, double extra) {
  // The tolerance of float positions a few roundings away from a plane: relative to the volume's
  // distance from the origin and its size.
  double scale = 0;
  for (const FacePlane& f : faces) scale = std::max(scale, std::abs(f[3]));
  const double tolerance = 4e-6 * scale + 1e-9 + extra;
  std::vector<std::uint8_t> flags(positions.size(), 0);
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const Vec3f& p = positions[v];
    for (std::size_t k = 0; k < 6; ++k) {
      const FacePlane& f = faces[k];
      const double d = f[0] * p.x + f[1] * p.y + f[2] * p.z - f[3];
      if (std::abs(d) <= tolerance) flags[v] |= static_cast<std::uint8_t>(1u << k);
    }
  }
  return flags;
}

}  // namespace isoslab
