// What an extraction run did (runExtract's result), and its JSON form: the `--report` file of
// `isoslab extract` and the dict of Python's isoslab.extract().
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/volume_info.h"
#include "io/label_components.h"
#include "metrics/mesh_stats.h"
#include "process/decimation.h"
#include "process/smoothing.h"

namespace isoslab {

/// Parts of ExtractReport, at namespace scope: clang cannot use a nested struct's default member
/// initializers (std::optional<Nested>::emplace) before the enclosing struct is complete.
struct ExtractIsoHistogram {
  std::size_t bins = 0;
  std::array<double, 2> range{};
  bool rangeFromReader = false;
  int passes = 0;
  std::size_t firstInsideBin = 0;
};

struct ExtractRoi {
  LatticeBox box;
  std::vector<double> requested;
  std::string space;  // "voxel" or "physical"
  bool clipped = false;
  std::array<std::int64_t, 3> inputDims{};
};

struct ExtractSmoothing {
  SmoothOptions options;
  std::uint64_t peakChunks = 0;
  std::uint64_t peakVertices = 0;
};

struct ExtractDecimation {
  double ratio = 1;
  double maxError = 0;
  double distanceBoundVoxels = 0.5;
  double voxelSize = 1;
  DecimationReport result;
};

/// One label's surface (label runs).
struct ExtractLabel {
  std::int32_t value = 0;
  std::string name;           // the table's, else the value
  std::optional<double> iso;  // several iso values: this surface's (value is its place, from 1)
  std::array<std::uint8_t, 3> color{};
  bool colorFromTable = false;
  int layer = 0;  // a .seg.nrrd's layer
  std::int64_t voxels = 0;
  double voxelVolume = 0;     // voxels times one voxel's volume, in output units
  MeshStats stats;            // edges and euler only with topology
  bool topology = false;      // ExtractSettings::labelTopology
  bool measured = true;       // area and mesh volume (ExtractSettings::labelMeasures)
  std::uint64_t splits = 0;   // vertices split where its voxels touch at an edge or a corner
  std::uint64_t pinches = 0;  // extra fans kept at a vertex where three labels meet
  std::string path;           // its file, with a pattern output
  /// With --smooth: its vertices' largest move and how many the displacement limit held back.
  std::optional<std::pair<double, std::int64_t>> smoothing;
  /// With per-label component rules: its components found and dropped, and the voxels moved.
  std::optional<LabelChange> components;
};

/// Where two labels touch (label runs): the smaller value first.
struct ExtractInterface {
  std::int32_t a = 0, b = 0;
  std::uint64_t triangles = 0;
  double area = 0;
  int layer = 0;  // the layer of both (a segmentation read with every layer)
};

struct ExtractReport {
  std::vector<std::string> inputs;
  std::string reader;
  std::string method;  // as the header names it ("mc", "mt6", ...)
  double iso = 0;
  /// "value", "suggested by the input", "auto (Otsu, 256 bins)", "bone (300 HU)".
  std::string isoSource;
  /// The iso request as given ("auto", "bone"); empty for a number or the input's suggestion.
  std::string isoRequest;
  /// A note on how the iso value was chosen, naming settings as `iso` (core/error.h); may be empty.
  std::string isoNote;
  using IsoHistogram = ExtractIsoHistogram;
  std::optional<IsoHistogram> isoHistogram;  // --iso auto

  std::array<std::int64_t, 3> dims{};
  using Roi = ExtractRoi;
  std::optional<Roi> roi;
  std::array<double, 3> spacing{};
  std::array<double, 6> volumeBounds{};
  std::string voxelType;
  std::string space;  // the header's name of the output space
  bool normals = false;
  /// The values read (NaN skipped, shortest float form); empty when every value was NaN.
  std::optional<std::array<double, 2>> valueRange;
  /// The readers' warnings, then the other ranks', then the run's own; settings named in backticks.
  std::vector<std::string> warnings;
  /// How many of `warnings` the readers gave while the input was opened (shown before the run).
  std::size_t openingWarnings = 0;

  MeshStats stats;
  using Smoothing = ExtractSmoothing;
  std::optional<Smoothing> smoothing;
  using Decimation = ExtractDecimation;
  std::optional<Decimation> decimation;
  /// The connected components, and (with filters) the filter's work, as the report writes them:
  /// one-line JSON text (componentsJson, componentFilterJson of metrics/), summarised, the
  /// largest listed.
  std::string componentsJson;
  std::string componentFilterJson;  // empty: no filter (label runs: the per-label rules' summary)
  /// The paper's measures against a sphere (sphereJson of metrics/), as JSON text; empty: none.
  std::string sphereJson;

  struct Seconds {
    double read = 0, extract = 0, write = 0, total = 0;
    std::optional<double> componentPass;
  };
  Seconds seconds;
  int ranks = 1;
  std::size_t ringBytes = 0;
  double peakRssMib = 0;
  struct Output {
    std::string path;
    std::int64_t bytes = 0;
    std::int64_t binaryPlyBytes = 0;
    std::vector<std::pair<std::string, double>> details;  // the writer's own (MeshFileSink::details)
  };
  Output output;
  /// Label runs: per selected label with a surface, ascending; the interfaces between labels.
  std::vector<ExtractLabel> labels;
  std::vector<ExtractInterface> interfaces;
  bool labelRun = false;
  int layers = 1;  // label runs: the layers read in one pass (a layered segmentation)
};

/// The report as the JSON text of `isoslab extract --report` (two-space indent, no final newline).
/// `spell` renders the settings that messages name in backticks (the program: as flags). Throws
/// isoslab::Error naming `what` when a number in it is not finite (metrics/report.h, reportText).
std::string extractReportText(const ExtractReport& report, const std::string& what,
                              const std::function<std::string(const std::string&)>& spell = {});

}  // namespace isoslab
