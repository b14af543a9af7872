// Every setting of an extraction run (`isoslab extract`), as typed values: what the program parses
// its options into, and what Python's isoslab.extract() and a C++ caller fill in.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh_sink.h"
#include "extract/extractor.h"
#include "io/open_source.h"
#include "metrics/component_filter.h"
#include "metrics/sphere_metrics.h"
#include "process/smoothing.h"
#include "render/camera.h"
#include "render/rasterizer.h"
#include "stream/iso_choice.h"

namespace isoslab {

class RankGroup;

/// The coordinates of the mesh: the input's own frame (LPS for DICOM), LPS, RAS, or lattice indices.
enum class OutputSpace : std::uint8_t { kPhysical, kLps, kRas, kVoxel };

/// "physical", "lps", "ras", "voxel".
std::string_view outputSpaceName(OutputSpace space) noexcept;
std::optional<OutputSpace> parseOutputSpace(std::string_view name) noexcept;

/// How a region of interest is given: lattice indices, or output coordinates (of `space`).
enum class RoiSpace : std::uint8_t { kVoxel, kPhysical };

/// An image rendered from the triangles as they stream past (`--preview`): the image alone is held.
struct PreviewSettings {
  std::string path;  // empty: none
  render::View view;
  int width = 800;
  int height = 800;
  /// Gouraud shading; empty: when the mesh has normals.
  std::optional<bool> smooth;
  render::Rgb background{255, 255, 255};
};

/// Which labels of a label map to mesh (--labels): every one but the background, or a list of
/// values, ranges and names (names need a label table or names in the file).
struct LabelRequest {
  bool all = true;
  std::vector<std::array<std::int32_t, 2>> ranges;  // inclusive; a single value is [v, v]
  std::vector<std::string> names;
};

/// "all", or a comma-separated list of values ("12"), ranges ("3-7", "-4--2") and names. Throws
/// SettingError naming `labels` for an empty item or a range whose ends are reversed.
LabelRequest parseLabelRequest(const std::string& text);

/// Whether an output path is a pattern of one file per surface: it holds {name}, {label} or {iso}.
bool isOutputPattern(const std::string& path) noexcept;

struct ExtractSettings {
  /// One volume: DICOM folders or files, a raw file or pattern, any other reader's file, or a
  /// phantom spec ("phantom:head?n=64").
  std::vector<std::string> inputs;
  /// How to read them: DICOM series choice, raw layout, spacing for stacks, NIfTI transform.
  SourceOptions source;
  /// The mesh: .ply, .stl, .obj, .glb, .drc or .3mf, by extension. Required. With labels, a pattern
  /// (isOutputPattern) writes one file per label, and a .ply the whole label complex.
  std::string output;
  /// A JSON report of the run (extractReportText), written with the mesh; empty: none.
  std::string reportPath;
  /// Label surfaces: measure each label's topology (edges, closedness, Euler characteristic), the
  /// costliest part of the label split (a quarter of a run on an atlas). The program asks for it
  /// only with --report; without it, and with the complex written to one .ply, the split also
  /// skips each label's vertices and bounds.
  bool labelTopology = true;
  /// --decimate: measure the one-sided distance of the decimated surface to the original (every
  /// output triangle's centroid and edge midpoints), for the report; about a tenth of the
  /// decimation's time. The program asks for it only with --report.
  bool measureDecimation = true;
  /// Label surfaces: measure each label's area and enclosed volume, and the interfaces between
  /// labels (a tenth of a run on an atlas). A .glb output measures them whatever this says (its
  /// nodes carry them); the program asks for them only with --report. Triangles are always counted.
  bool labelMeasures = true;

  OutputSpace space = OutputSpace::kPhysical;
  /// A number, Otsu's threshold ("auto") or a named CT value; empty: the input's suggestion (phantoms).
  std::optional<IsoRequest> iso;
  /// Several values (two or more; `iso` then empty): one surface each, from one read of the input,
  /// written as label surfaces are (a pattern with {iso}, a .glb of a mesh per value, or a .ply).
  std::vector<double> isos;
  Method method = Method::kMarchingCubes;
  /// Vertex normals from the field's gradient.
  bool normals = false;
  /// The field is outside beyond the volume's faces: the surface is capped there, and closed.
  bool closeBoundary = false;
  /// Printable outputs (.stl, .3mf) merge coincident vertices and drop the zero-area triangles
  /// between them (process/degenerate.h); true writes them as extracted.
  bool keepDegenerate = false;
  /// A label map: one surface per selected label, in one pass (extract/label_extractor.h). Empty:
  /// an iso-surface, unless the input says it holds labels and `iso` is empty.
  std::optional<LabelRequest> labels;
  /// Names and colours of the labels (io/label_table.h); empty: the file's own, else none.
  std::string labelTable;
  /// Measure the mesh against this sphere (output coordinates); phantom spheres are measured anyway.
  std::optional<Sphere> sphere;

  /// Extraction threads; 0: the cores this process may use, at most 8, shared among the ranks on
  /// one machine. The output is the same for every count.
  int threads = 0;
  /// MiB for what grows with threads (slices in flight, caches, .glb encoders on threads).
  int maxMemoryMiB = 256;
  /// The cost model's smallest volume for threads (-1: its default); for tests of threaded paths.
  std::int64_t sequentialVoxels = -1;

  /// Draco (.glb, .drc): level 0..10; bits per position component (0: the fewest whose step is at
  /// most 1/64 voxel).
  int dracoLevel = 7;
  int quantBits = 0;
  /// .glb: triangles per chunk (a chunk closes at the next slab boundary).
  std::int64_t chunkTriangles = std::int64_t{1} << 19;
  /// .glb: Draco-compressed chunks, else plain accessors.
  bool draco = true;
  /// .glb: a root node maps the output space to glTF's Y-up frame in metres.
  bool gltfFrame = true;

  /// Extract only this box: i0,j0,k0,i1,j1,k1 (lattice indices, inclusive, clipped to the volume)
  /// or, with RoiSpace::kPhysical, x0,y0,z0,x1,y1,z1 in output coordinates.
  std::optional<std::array<double, 6>> roi;
  RoiSpace roiSpace = RoiSpace::kVoxel;

  /// Connected-component filters (a first pass over the input); seedReach is the job's to set.
  ComponentRules components;
  /// Smoothing in the stream (iterations 0: off).
  SmoothOptions smoothing;
  /// Whether smoothing.passBand was given: label surfaces default to kLabelPassBand otherwise.
  bool passBandGiven = false;
  /// Decimation: keep this fraction of the triangles, and/or stay within maxError voxels
  /// (1 and 0: off).
  double decimate = 1.0;
  double maxError = 0;

  PreviewSettings preview;

  /// Processes that share the run under mpirun (not owned; nullptr: this process alone). Every
  /// rank calls runExtract() with the same settings; rank 0 alone writes and reports.
  RankGroup* ranks = nullptr;

  /// A caller's own volume (Python's NumPy arrays): when set, the run reads the source this makes,
  /// once per pass, instead of opening `inputs`, which then only name it in messages and the report.
  /// For library callers (Python's label_surfaces): a label run hands each label's surface to
  /// the sink this returns for (label, name) instead of a file, and `output` may be empty. The
  /// sinks must outlive the run; they see the label's own stream (core/mesh_sink.h).
  std::function<MeshSink*(std::int32_t label, const std::string& name)> labelSinks;
  std::function<std::unique_ptr<SliceSource>()> openVolume;
};

/// Library text with the settings it names in backticks (core/error.h: `channel`, `raw_dims`,
/// `output`) spelled as the isoslab program's options (--channel, --raw-dims, -o), so that every
/// front end gives the program's one line. Other text, backticks included, is kept.
std::string settingsAsFlags(const std::string& text);

/// Checks what can be checked without opening the input: ranges, and outputs that name one file.
/// Throws SettingError naming the setting in backticks by its snake_case name (`threads`,
/// `report`), as core/error.h describes. runExtract() calls it first.
void checkExtractSettings(const ExtractSettings& settings);

/// The checks of a label run: the settings that label surfaces do not take yet, and an output
/// that is a pattern or a .ply. runExtract() calls it when settings.labels is set or the input
/// turns out to be a label map.
void checkLabelSettings(const ExtractSettings& settings);

}  // namespace isoslab
