// Helpers shared by the tests: in-memory sources, one-call extraction, running the CLI, temp dirs.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "encode/indexed_mesh.h"
#include "extract/extractor.h"
#include "io/slice_source.h"
#include "metrics/mesh_stats.h"

namespace isoslab::testing {

/// A volume held in a vector, x fastest; only tests hold whole volumes.
class VectorSource final : public SliceSource {
 public:
  VectorSource(std::array<std::int64_t, 3> dims, std::vector<float> values);
  /// Fills by a function of the lattice point.
  VectorSource(std::array<std::int64_t, 3> dims,
               const std::function<float(std::int64_t, std::int64_t, std::int64_t)>& f);
  VolumeInfo& mutableInfo() { return info_; }
  const VolumeInfo& info() const noexcept override { return info_; }
  bool readSlice(std::span<float> slice) override;
  /// With lending on, the pipeline borrows the slices instead of copying them.
  void setLending(bool lending) { lending_ = lending; }
  bool lendsSlices() const noexcept override { return lending_; }
  const float* lendSlice() override;
  /// Slices handed out so far.
  std::int64_t slicesRead() const { return next_; }

 private:
  VolumeInfo info_;
  std::vector<float> values_;
  std::int64_t next_ = 0;
  bool lending_ = false;
};

struct Extraction {
  IndexedMesh mesh;
  MeshStats stats;
};

/// Runs the pipeline on `source` (physical frame) into memory, measuring as it goes.
Extraction extract(SliceSource& source, Method method, double iso, bool normals = false);
/// Runs the pipeline with `options` (padding the source for closeBoundary) on `threads` threads,
/// with the header the command line gives (volume faces included).
Extraction extract(std::unique_ptr<SliceSource> source, const ExtractOptions& options, int threads = 1);
/// Same for a spec that openSource() understands (phantoms).
Extraction extract(const std::string& input, Method method, double iso, bool normals = false);

struct CliResult {
  int exitCode = -1;
  std::string out;
  std::string err;
};

/// Runs the isoslab program with `args` (passed through the shell; quote as needed).
CliResult runCli(const std::string& args);

/// Why the real glTF clients (node, and the npm packages scripts/test.sh installs in `npm`) cannot
/// run here, or empty when they can.
std::string gltfClientsMissing(const std::string& npm);

/// A fresh, empty folder for one test.
std::string tempDir();

/// ../shared/data/<name>, or empty if absent.
std::string sharedData(const std::string& name);

/// The whole contents of a file (empty if it cannot be read).
std::string slurp(const std::string& path);

/// Number of regular files in `folder`, hidden ones included.
int fileCount(const std::string& folder);

inline constexpr auto& kAllMethods = kMethods;

}  // namespace isoslab::testing
