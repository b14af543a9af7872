// 3MF output (the 3D Manufacturing Format, for printers) through Debian's lib3mf 1.8.
//
// A 3MF file is a zip package holding one XML model, which lib3mf builds whole before it writes:
// a 3MF output is therefore not streamed. The writer keeps the mesh's positions and triangles
// (24 bytes a vertex and 12 a triangle) and hands them to lib3mf at the end, which holds its own
// copy while it writes. Each surface is one mesh object, named and coloured (a base material of
// the label's colour), with a build item; the unit is the millimetre.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "encode/mesh_writer.h"

namespace isoslab {

/// One .3mf of one or more mesh objects. addObject() in the order the objects should appear;
/// write() then writes the file (through AtomicFile, committed with the run).
class ThreeMfModel {
 public:
  explicit ThreeMfModel(std::string path);
  ~ThreeMfModel();
  ThreeMfModel(const ThreeMfModel&) = delete;
  ThreeMfModel& operator=(const ThreeMfModel&) = delete;

  /// Checks that the file can be written (opens its temporary file).
  void begin();
  /// Adds a mesh object: the vertices that `triangles` reference, renumbered in order of first
  /// use. `color` as sRGB; none gives the object no material. No triangles: no object.
  void addObject(const std::string& name, const std::optional<std::array<std::uint8_t, 3>>& color,
                 const std::vector<Vec3f>& positions, const std::vector<Triangle>& triangles);
  /// Writes the file; returns its size.
  std::int64_t write();
  const std::string& path() const noexcept { return path_; }

 private:
  // lib3mf's handles (PLib3MFBase*).
  using Handle = void**;
  [[noreturn]] void fail(Handle instance, const char* what) const;

  std::string path_;
  Handle model_ = nullptr;
  Handle materials_ = nullptr;  // a base material group, made with the first colour
  std::uint32_t materialGroup_ = 0;
  int objects_ = 0;
  static constexpr int kMaxObjects = 10000;
  std::unique_ptr<AtomicFile> file_;
};

/// A MeshSink that gathers one surface and adds it to a model: its own (a plain .3mf output) or a
/// shared one (label surfaces: one object each). Triangles may reference any earlier vertex (a
/// DegenerateCollapseSink with remap in front of it merges vertices across chunks).
class ThreeMfWriter final : public MeshFileSink {
 public:
  /// A .3mf of this surface alone.
  explicit ThreeMfWriter(std::string path);
  /// An object of `model`, which the caller writes.
  ThreeMfWriter(ThreeMfModel& model, std::string name, std::array<std::uint8_t, 3> color);
  ~ThreeMfWriter() override;

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  std::int64_t bytes() const noexcept override { return bytes_; }

 private:
  std::unique_ptr<ThreeMfModel> own_;
  ThreeMfModel* model_ = nullptr;
  std::string name_;
  std::optional<std::array<std::uint8_t, 3>> color_;
  VertexId first_ = 0;
  bool started_ = false;
  std::vector<Vec3f> positions_;
  std::vector<Triangle> triangles_;
  std::int64_t bytes_ = 0;
};

}  // namespace isoslab
