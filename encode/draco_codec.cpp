#include "encode/draco_codec.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/interrupt.h"

namespace isoslab {

int defaultQuantBits(double range, double voxel) noexcept {
  int bits = 8;
  while (bits < 30 && range / (std::ldexp(1.0, bits) - 1.0) > voxel / 64.0) ++bits;
  return bits;
}

std::int32_t dracoQuantized(float value, float origin, const DracoSettings& s) noexcept {
  const float maxQ = static_cast<float>((1u << s.quantBits) - 1u);
  const float inverseDelta = maxQ / s.range;
  return static_cast<std::int32_t>(std::floor((value - origin) * inverseDelta + 0.5f));
}

float dracoDequantized(float value, float origin, const DracoSettings& s) noexcept {
  // Draco's quantizer: q = floor((v - origin) * max / range + 0.5), then v' = q * (range / max) + origin.
  const float maxQ = static_cast<float>((1u << s.quantBits) - 1u);
  const float inverseDelta = maxQ / s.range;
  const float v = value - origin;
  const auto q = static_cast<std::int32_t>(std::floor(v * inverseDelta + 0.5f));
  const float delta = s.range / maxQ;
  return static_cast<float>(q) * delta + origin;
}

std::vector<char> dracoEncode(IndexedMesh mesh, const DracoSettings& settings, const std::string& what,
                              DracoAttributeIds* ids) {
  DracoAttributeIds attributeIds;
  draco::Mesh m;
  const auto n = static_cast<std::uint32_t>(mesh.positions.size());
  m.set_num_points(n);
  draco::GeometryAttribute position;
  position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, sizeof(float) * 3, 0);
  const int positionId = m.AddAttribute(position, true, n);
  for (std::uint32_t v = 0; v < n; ++v) {
    m.attribute(positionId)->SetAttributeValue(draco::AttributeValueIndex(v), &mesh.positions[v]);
  }
  const bool normals = !mesh.normals.empty();
  if (normals) {
    draco::GeometryAttribute normal;
    normal.Init(draco::GeometryAttribute::NORMAL, nullptr, 3, draco::DT_FLOAT32, false, sizeof(float) * 3, 0);
    const int normalId = m.AddAttribute(normal, true, n);
    attributeIds.normal = normalId;
    for (std::uint32_t v = 0; v < n; ++v) {
      m.attribute(normalId)->SetAttributeValue(draco::AttributeValueIndex(v), &mesh.normals[v]);
    }
  }
  const bool seams = std::any_of(mesh.seamKeys.begin(), mesh.seamKeys.end(), [](std::uint32_t k) { return k != 0; });
  if (seams) {
    draco::GeometryAttribute seam;
    seam.Init(draco::GeometryAttribute::GENERIC, nullptr, 2, draco::DT_UINT16, false, sizeof(std::uint16_t) * 2, 0);
    const int seamId = m.AddAttribute(seam, true, n);
    attributeIds.seam = seamId;
    for (std::uint32_t v = 0; v < n; ++v) {
      const std::uint32_t key = mesh.seamKeys[v];
      const std::uint16_t halves[2] = {static_cast<std::uint16_t>(key & 0xFFFFu),
                                       static_cast<std::uint16_t>(key >> 16)};
      m.attribute(seamId)->SetAttributeValue(draco::AttributeValueIndex(v), halves);
    }
  }
  attributeIds.position = positionId;
  // The glTF extension names attributes by unique id; make them the attribute ids.
  for (int a = 0; a < m.num_attributes(); ++a) m.attribute(a)->set_unique_id(static_cast<std::uint32_t>(a));
  if (ids != nullptr) *ids = attributeIds;
  m.SetNumFaces(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const Triangle& t = mesh.triangles[f];
    m.SetFace(draco::FaceIndex(static_cast<std::uint32_t>(f)),
              {draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }
  mesh = IndexedMesh{};  // Draco holds its own copy now; free ours before its working memory grows
  draco::Encoder encoder;
  const int speed = 10 - settings.level;
  encoder.SetSpeedOptions(speed, speed);
  encoder.SetAttributeExplicitQuantization(draco::GeometryAttribute::POSITION, settings.quantBits, 3,
                                           settings.origin.data(), settings.range);
  if (normals) encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, settings.normalBits);
  // Seam marks are sparse and unrelated to their neighbours: no prediction compresses them best
  // (Philips skull, 4 chunks: 0.72% of the file against 0.89% with the difference predictor).
  if (seams) encoder.SetAttributePredictionScheme(draco::GeometryAttribute::GENERIC, draco::PREDICTION_NONE);
  draco::EncoderBuffer buffer;
  const draco::Status status = encoder.EncodeMeshToBuffer(m, &buffer);
  if (!status.ok()) throw Error(fmt::format("{}: Draco encoding failed: {}", what, status.error_msg_string()));
  return std::vector<char>(buffer.data(), buffer.data() + buffer.size());
}

IndexedMesh dracoDecode(const char* data, std::size_t size, const std::string& what, int seamId) {
  draco::DecoderBuffer buffer;
  buffer.Init(data, size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    throw Error(fmt::format("{}: not a decodable Draco mesh: {}", what, decoded.status().error_msg_string()));
  }
  const std::unique_ptr<draco::Mesh> m = std::move(decoded).value();
  const draco::PointAttribute* position = m->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (position == nullptr) throw Error(fmt::format("{}: the Draco mesh has no positions", what));
  const draco::PointAttribute* normal = m->GetNamedAttribute(draco::GeometryAttribute::NORMAL);
  const draco::PointAttribute* seam =
      seamId >= 0 ? m->GetAttributeByUniqueId(static_cast<std::uint32_t>(seamId)) : nullptr;
  if (seamId >= 0 && (seam == nullptr || seam->num_components() != 2)) {
    throw Error(fmt::format("{}: the Draco mesh lacks its seam attribute (unique id {})", what, seamId));
  }
  IndexedMesh mesh;
  mesh.positions.resize(m->num_points());
  if (seam != nullptr) mesh.seamKeys.resize(m->num_points());
  if (normal != nullptr) mesh.normals.resize(m->num_points());
  for (std::uint32_t p = 0; p < m->num_points(); ++p) {
    throwIfInterruptedEvery(p);
    float v[3];
    position->ConvertValue<float, 3>(position->mapped_index(draco::PointIndex(p)), v);
    mesh.positions[p] = {v[0], v[1], v[2]};
    if (normal != nullptr) {
      normal->ConvertValue<float, 3>(normal->mapped_index(draco::PointIndex(p)), v);
      mesh.normals[p] = {v[0], v[1], v[2]};
    }
    if (seam != nullptr) {
      std::uint16_t halves[2];
      seam->ConvertValue<std::uint16_t, 2>(seam->mapped_index(draco::PointIndex(p)), halves);
      mesh.seamKeys[p] = std::uint32_t{halves[0]} | (std::uint32_t{halves[1]} << 16);
    }
  }
  mesh.triangles.resize(m->num_faces());
  for (std::uint32_t f = 0; f < m->num_faces(); ++f) {
    const auto& face = m->face(draco::FaceIndex(f));
    mesh.triangles[f] = {face[0].value(), face[1].value(), face[2].value()};
  }
  return mesh;
}

}  // namespace isoslab
