#include "encode/draco_codec.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <fmt/format.h>

#include <cmath>
#include <cstring>

#include "io/error.h"

namespace isoslab {

int defaultQuantBits(double range, double voxel) noexcept {
  int bits = 8;
  while (bits < 30 && range / (std::ldexp(1.0, bits) - 1.0) > voxel / 64.0) ++bits;
  return bits;
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

std::vector<char> dracoEncode(IndexedMesh mesh, const DracoSettings& settings, const std::string& what) {
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
    for (std::uint32_t v = 0; v < n; ++v) {
      m.attribute(normalId)->SetAttributeValue(draco::AttributeValueIndex(v), &mesh.normals[v]);
    }
  }
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
  draco::EncoderBuffer buffer;
  const draco::Status status = encoder.EncodeMeshToBuffer(m, &buffer);
  if (!status.ok()) throw Error(fmt::format("{}: Draco encoding failed: {}", what, status.error_msg_string()));
  return std::vector<char>(buffer.data(), buffer.data() + buffer.size());
}

IndexedMesh dracoDecode(const char* data, std::size_t size, const std::string& what) {
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
  IndexedMesh mesh;
  mesh.positions.resize(m->num_points());
  if (normal != nullptr) mesh.normals.resize(m->num_points());
  for (std::uint32_t p = 0; p < m->num_points(); ++p) {
    float v[3];
    position->ConvertValue<float, 3>(position->mapped_index(draco::PointIndex(p)), v);
    mesh.positions[p] = {v[0], v[1], v[2]};
    if (normal != nullptr) {
      normal->ConvertValue<float, 3>(normal->mapped_index(draco::PointIndex(p)), v);
      mesh.normals[p] = {v[0], v[1], v[2]};
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
