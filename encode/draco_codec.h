// Draco encoding and decoding of one indexed triangle mesh, the building block of the .glb and
// .drc writers and of the decoders.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "encode/indexed_mesh.h"

namespace isoslab {

struct DracoSettings {
  /// 0 (fastest) .. 10 (smallest), as draco_encoder's -cl.
  int level = 7;
  /// Bits per position component; 0 chooses them from the volume (see defaultQuantBits).
  int quantBits = 0;
  int normalBits = 10;
  /// Explicit quantization grid shared by every chunk: origin and the edge of the cube it spans.
  std::array<float, 3> origin{};
  float range = 1;
};

/// The smallest bit count whose step, over a cube of edge `range`, is at most `voxel` / 64.
int defaultQuantBits(double range, double voxel) noexcept;

/// Draco attribute ids of an encoded mesh: position 0, then normal and the seam keys when present.
struct DracoAttributeIds {
  int position = 0;
  int normal = -1;
  int seam = -1;
};

/// Draco-encodes `mesh` (positions, optional normals, triangles, and seam keys when any is
/// non-zero, as a generic attribute of two 16-bit components: low half, high half) with
/// `settings`. `what` names the output in error messages.
std::vector<char> dracoEncode(IndexedMesh mesh, const DracoSettings& settings, const std::string& what,
                              DracoAttributeIds* ids = nullptr);

/// Decodes a Draco mesh; `seamId`, when not negative, is the unique id of the seam-key attribute.
/// Throws isoslab::Error naming `what`.
IndexedMesh dracoDecode(const char* data, std::size_t size, const std::string& what, int seamId = -1);

/// The grid index Draco's quantizer gives `value` on axis origin `origin` with `settings`' grid.
std::int32_t dracoQuantized(float value, float origin, const DracoSettings& settings) noexcept;

/// The position Draco reconstructs for `value` on axis origin `origin` with `settings`' grid.
float dracoDequantized(float value, float origin, const DracoSettings& settings) noexcept;

}  // namespace isoslab
