// What a mesh file says about itself beyond its geometry: the method, iso value and coordinate
// space that made it, and the volume's box and faces, so that `metrics` and `decode` can tell the
// volume's faces from holes without the volume.
//
// The same text lines go into PLY comments, OBJ comments and (shortened) the STL header:
//   isoslab METHOD iso V space S
//   SPACE=LPS                      (3D Slicer's tag; RAS for --space ras; none for voxel or
//                                   unspecified physical frames, which Slicer reads as LPS)
//   volume_bounds xmin ymin zmin xmax ymax zmax
//   volume_faces nx ny nz d ... (six planes, MeshHeader::volumeFaces order)
//   position_tolerance T           (decoded .glb: half Draco's quantization step)
// A .glb carries the same fields in asset.extras.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh_sink.h"

namespace isoslab {

struct MeshMetadata {
  std::string method;
  std::optional<double> iso;
  std::string space;
  std::optional<std::array<double, 6>> volumeBounds;
  std::optional<VolumeFaces> volumeFaces;
  /// How far the stored positions may lie from the extraction's (Draco's quantization step / 2).
  double positionTolerance = 0;
};

/// "LPS" or "RAS" for the output spaces that are one of them, else "".
std::string spaceTag(const std::string& space);

/// The metadata lines of `header`, without comment markers.
std::vector<std::string> metadataLines(const MeshHeader& header);

/// Reads one metadata line (without its comment marker) into `meta`; other lines are ignored.
void parseMetadataLine(const std::string& line, MeshMetadata& meta);

/// The header a writer needs to write `meta` back out (decode).
MeshHeader headerFromMetadata(const MeshMetadata& meta);

/// The header for re-encoding a mesh read from a file (`isoslab decode`): headerFromMetadata, with
/// normals when the mesh has them and, when the file states no volume, the positions' own box as
/// volumeBounds (the Draco grid).
MeshHeader headerForDecodedMesh(const MeshMetadata& meta, const std::vector<Vec3f>& positions, bool normals);

/// Per position, the BoundaryFace bits of the volume faces it lies on (within a rounding
/// tolerance of the plane, plus `tolerance` for stored positions that were quantized), as extraction
/// marks them; for measuring a mesh read from a file.
std::vector<std::uint8_t> volumeFaceFlags(const std::vector<Vec3f>& positions, const VolumeFaces& faces,
                                          double tolerance = 0);

}  // namespace isoslab
