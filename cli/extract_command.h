// `isoslab extract`: its options, parsed into ExtractSettings (job/extract_settings.h), and the
// run's lines on stderr. The run itself is the library's runExtract (job/extract_job.h).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "cli/render.h"
#include "cli/source_options.h"
#include "job/extract_settings.h"

namespace isoslab {
class RankGroup;
}

namespace isoslab::cli {

/// The options as parsed (strings where CLI11 checks a choice or a list).
struct ExtractArgs {
  std::vector<std::string> inputs;
  std::string space = "physical";
  std::string labels;      // all, or values, ranges and names (--labels)
  std::string labelTable;  // --label-table
  std::string iso;         // a number, auto, bone or skin (checked by isoValue()); empty: the input's suggestion
  std::string method = "mc";
  std::string output;
  bool normals = false;
  bool closeBoundary = false;
  bool keepDegenerate = false;
  std::string report;
  bool quiet = false;
  std::string sphere;
  int threads = 0;
  int maxMemory = 256;                 // MiB
  std::int64_t sequentialVoxels = -1;  // the cost model's default
  int dracoLevel = 7;
  int quantBits = 0;
  std::int64_t chunkTriangles = 1 << 19;
  std::string draco = "on";
  std::string gltfFrame = "gltf";
  std::string preview;  // a PNG rendered as the triangles stream past
  cli::ImageArgs previewImage;
  RawArgs raw;
  std::string roi;  // i0,j0,k0,i1,j1,k1 or, with roiSpace "physical", x0,y0,z0,x1,y1,z1
  std::string roiSpace = "voxel";
  // Component filters (0 or empty: not given).
  std::uint64_t keepLargest = 0;
  std::string componentMeasure = "triangles";
  std::uint64_t minTriangles = 0;
  double minVolume = -1;
  std::string seed;  // x,y,z in output coordinates
  // Smoothing.
  int smooth = 0;
  std::string smoothMethod = "sinc";
  double passBand = 0.08;
  bool passBandGiven = false;
  std::string smoothFaces = "slide";
  std::string smoothNormals = "smoothed";
  // Decimation (1 and 0: off).
  double decimate = 1.0;
  double maxError = 0;
};

/// Adds the extract command and its options to `app`.
CLI::App* addExtractCommand(CLI::App& app, ExtractArgs& args);

/// The settings the options give (the validators have checked each option).
ExtractSettings extractSettings(const ExtractArgs& args, RankGroup* ranks);

/// Runs the job: notes, warnings and the progress line on stderr (warnings even with --quiet),
/// then the summary line. Rank 0 alone prints under mpirun. Returns the exit status (0).
int runExtractCommand(const ExtractArgs& args, RankGroup* ranks);

}  // namespace isoslab::cli
