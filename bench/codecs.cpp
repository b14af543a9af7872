// Draco's encoder options, and meshoptimizer's EXT_meshopt_compression codec, on one mesh: bytes,
// encode time and decode time of each, medians of R runs, as a Markdown table.
//
// Draco rows: the speed options (draco_encoder's -cl L is speed 10 - L for both encoding and
// decoding), the encoding and decoding speeds apart, the edgebreaker and sequential methods, and
// the prediction schemes for positions, all with positions quantized to B bits over the mesh's
// bounding cube (as isoslab's writers do).
//
// meshopt rows: positions quantized to B bits in 16-bit integers (KHR_mesh_quantization, padded
// to 8 bytes a vertex), triangles reordered for the vertex cache and vertices for fetch (part of
// the encode time), then meshopt_encodeIndexBuffer and meshopt_encodeVertexBuffer, the byte
// streams of EXT_meshopt_compression's TRIANGLES and ATTRIBUTES modes; and the same after gzip
// (zlib level 6), which the extension expects of a server. Decoding is meshopt's decoders (and
// zlib's inflate first for the gzip row).
//
// Usage: isoslab_codecs MESH [--bits B] [--runs R]   (MESH: anything isoslab's readers read)
#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <fmt/format.h>
#include <meshoptimizer.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "core/error.h"
#include "encode/mesh_reader.h"

namespace {

using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double timed(const std::function<void()>& fn) {
  const auto t = Clock::now();
  fn();
  return std::chrono::duration<double>(Clock::now() - t).count();
}

struct Bounds {
  float origin[3];
  float range;
};

Bounds boundsOf(const isoslab::IndexedMesh& m) {
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (const auto& p : m.positions) {
    const float c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], c[a]);
      hi[a] = std::max(hi[a], c[a]);
    }
  }
  Bounds b{{lo[0], lo[1], lo[2]}, std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-6f})};
  return b;
}

std::unique_ptr<draco::Mesh> toDraco(const isoslab::IndexedMesh& mesh) {
  auto m = std::make_unique<draco::Mesh>();
  const auto n = static_cast<std::uint32_t>(mesh.positions.size());
  m->set_num_points(n);
  draco::GeometryAttribute position;
  position.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, sizeof(float) * 3, 0);
  const int id = m->AddAttribute(position, true, n);
  for (std::uint32_t v = 0; v < n; ++v) {
    m->attribute(id)->SetAttributeValue(draco::AttributeValueIndex(v), &mesh.positions[v]);
  }
  m->SetNumFaces(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    m->SetFace(draco::FaceIndex(static_cast<std::uint32_t>(f)),
               {draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }
  return m;
}

struct Row {
  std::string codec;
  std::size_t bytes = 0;
  double encode = 0;
  double decode = 0;
};

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  int bits = 15;
  int runs = 3;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--bits" && a + 1 < argc) {
      bits = std::stoi(argv[++a]);
    } else if (arg == "--runs" && a + 1 < argc) {
      runs = std::stoi(argv[++a]);
    } else {
      path = arg;
    }
  }
  try {
    const isoslab::IndexedMesh mesh = isoslab::readMesh(path);
    const Bounds b = boundsOf(mesh);
    const auto dmesh = toDraco(mesh);
    std::vector<Row> rows;

    // Draco: one row per encoder setup.
    struct DracoSetup {
      std::string name;
      int encodeSpeed, decodeSpeed;
      int method;      // -1: the encoder's choice
      int prediction;  // -1: the encoder's choice
    };
    std::vector<DracoSetup> setups;
    for (int level = 0; level <= 10; ++level) {
      setups.push_back({fmt::format("draco -cl {} (speed {})", level, 10 - level), 10 - level, 10 - level, -1, -1});
    }
    setups.push_back({"draco encode speed 5, decode speed 3", 5, 3, -1, -1});
    setups.push_back({"draco encode speed 3, decode speed 5", 3, 5, -1, -1});
    setups.push_back({"draco speed 3, sequential", 3, 3, draco::MESH_SEQUENTIAL_ENCODING, -1});
    const std::pair<const char*, int> schemes[] = {
        {"difference", draco::PREDICTION_DIFFERENCE},
        {"parallelogram", draco::MESH_PREDICTION_PARALLELOGRAM},
        {"multi-parallelogram", draco::MESH_PREDICTION_MULTI_PARALLELOGRAM},
        {"constrained multi-parallelogram", draco::MESH_PREDICTION_CONSTRAINED_MULTI_PARALLELOGRAM}};
    for (const auto& [name, scheme] : schemes) {
      setups.push_back({fmt::format("draco speed 3, {}", name), 3, 3, -1, scheme});
    }
    for (const DracoSetup& s : setups) {
      draco::Encoder encoder;
      encoder.SetSpeedOptions(s.encodeSpeed, s.decodeSpeed);
      encoder.SetAttributeExplicitQuantization(draco::GeometryAttribute::POSITION, bits, 3, b.origin, b.range);
      if (s.method >= 0) encoder.SetEncodingMethod(s.method);
      if (s.prediction >= 0) {
        encoder.SetAttributePredictionScheme(draco::GeometryAttribute::POSITION, s.prediction);
      }
      std::vector<double> enc, dec;
      draco::EncoderBuffer buffer;
      std::size_t faces = 0;
      for (int r = 0; r < runs; ++r) {
        buffer.Clear();
        enc.push_back(timed([&] {
          const draco::Status status = encoder.EncodeMeshToBuffer(*dmesh, &buffer);
          if (!status.ok()) throw isoslab::Error(fmt::format("{}: {}", s.name, status.error_msg_string()));
        }));
        dec.push_back(timed([&] {
          draco::DecoderBuffer in;
          in.Init(buffer.data(), buffer.size());
          draco::Decoder decoder;
          auto decoded = decoder.DecodeMeshFromBuffer(&in);
          if (!decoded.ok()) {
            throw isoslab::Error(
                fmt::format("{}: the mesh did not decode: {}", s.name, decoded.status().error_msg_string()));
          }
          faces = decoded.value()->num_faces();
        }));
      }
      // Draco drops triangles that quantization makes degenerate; say so when it does.
      rows.push_back({faces == mesh.triangles.size() ? s.name : fmt::format("{} ({} triangles decoded)", s.name, faces),
                      buffer.size(), median(enc), median(dec)});
    }

    // meshoptimizer: quantize, reorder (or not: isoslab's chunks come in slab order, which is
    // already local), encode (and gzip); decode.
    for (const bool reorder : {true, false}) {
      const std::size_t nv = mesh.positions.size();
      std::vector<std::size_t> sizes;
      std::vector<double> enc, dec, gzEnc, gzDec;
      std::size_t raw = 0, gz = 0;
      for (int r = 0; r < runs; ++r) {
        std::vector<unsigned char> stream;
        std::vector<unsigned int> indices;
        const double e = timed([&] {
          const float scale = static_cast<float>((1u << bits) - 1u) / b.range;
          std::vector<std::uint16_t> q(nv * 4, 0);
          for (std::size_t v = 0; v < nv; ++v) {
            const float c[3] = {mesh.positions[v].x, mesh.positions[v].y, mesh.positions[v].z};
            for (int a = 0; a < 3; ++a) {
              q[v * 4 + static_cast<std::size_t>(a)] =
                  static_cast<std::uint16_t>(std::lround((c[a] - b.origin[a]) * scale));
            }
          }
          indices.resize(mesh.triangles.size() * 3);
          for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
            for (std::size_t k = 0; k < 3; ++k) indices[t * 3 + k] = mesh.triangles[t][k];
          }
          if (reorder) meshopt_optimizeVertexCache(indices.data(), indices.data(), indices.size(), nv);
          std::vector<std::uint16_t> fetched(q.size());
          meshopt_optimizeVertexFetch(fetched.data(), indices.data(), indices.size(), q.data(), nv, 8);
          std::vector<unsigned char> ib(meshopt_encodeIndexBufferBound(indices.size(), nv));
          ib.resize(meshopt_encodeIndexBuffer(ib.data(), ib.size(), indices.data(), indices.size()));
          std::vector<unsigned char> vb(meshopt_encodeVertexBufferBound(nv, 8));
          vb.resize(meshopt_encodeVertexBuffer(vb.data(), vb.size(), fetched.data(), nv, 8));
          stream = ib;
          stream.insert(stream.end(), vb.begin(), vb.end());
          raw = stream.size();
          sizes = {ib.size(), vb.size()};
        });
        enc.push_back(e);
        dec.push_back(timed([&] {
          std::vector<unsigned int> outIndices(indices.size());
          std::vector<std::uint16_t> outVertices(nv * 4);
          const int ri = meshopt_decodeIndexBuffer(outIndices.data(), outIndices.size(), 4, stream.data(), sizes[0]);
          const int rv = meshopt_decodeVertexBuffer(outVertices.data(), nv, 8, stream.data() + sizes[0], sizes[1]);
          // The index codec may rotate a triangle's corners (keeping its winding): compare rotations.
          auto rotated = [](const unsigned* t) {
            const int k = t[0] <= t[1] && t[0] <= t[2] ? 0 : (t[1] <= t[2] ? 1 : 2);
            return std::array<unsigned, 3>{t[k], t[(k + 1) % 3], t[(k + 2) % 3]};
          };
          bool same = ri == 0 && rv == 0;
          for (std::size_t t = 0; same && t < indices.size(); t += 3) {
            same = rotated(&outIndices[t]) == rotated(&indices[t]);
          }
          if (!same) {
            throw isoslab::Error(fmt::format("meshopt: the mesh did not decode whole ({}, {})", ri, rv));
          }
        }));
        std::vector<unsigned char> packed(compressBound(static_cast<uLong>(stream.size())));
        uLongf packedSize = static_cast<uLongf>(packed.size());
        gzEnc.push_back(e + timed([&] {
                          compress2(packed.data(), &packedSize, stream.data(), static_cast<uLong>(stream.size()), 6);
                        }));
        gz = packedSize;
        gzDec.push_back(dec.back() + timed([&] {
                          std::vector<unsigned char> back(stream.size());
                          uLongf backSize = static_cast<uLongf>(back.size());
                          uncompress(back.data(), &backSize, packed.data(), packedSize);
                        }));
      }
      rows.push_back({reorder ? "meshopt, cache-optimized (EXT_meshopt_compression streams)" : "meshopt, slab order",
                      raw, median(enc), median(dec)});
      rows.push_back({reorder ? "meshopt, cache-optimized, + gzip 6" : "meshopt, slab order, + gzip 6", gz,
                      median(gzEnc), median(gzDec)});
    }

    fmt::print("Mesh: {}, {} triangles, {} vertices; positions quantized to {} bits; medians of {} runs\n\n", path,
               mesh.triangles.size(), mesh.positions.size(), bits, runs);
    fmt::print("| codec | bytes | bits/triangle | encode s | decode s |\n|---|---|---|---|---|\n");
    for (const Row& r : rows) {
      fmt::print("| {} | {} | {:.2f} | {:.3f} | {:.3f} |\n", r.codec, r.bytes,
                 8.0 * static_cast<double>(r.bytes) / static_cast<double>(mesh.triangles.size()), r.encode, r.decode);
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "isoslab_codecs: {}\n", e.what());
    return 1;
  }
  return 0;
}
