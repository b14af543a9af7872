// The steps of runExtract (job/extract_job.cpp) that stand on their own: opening and cropping the
// input, choosing the iso value, and the pieces of the report and the sinks that the settings give.
#pragma once

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "core/volume_info.h"
#include "encode/mesh_writer.h"
#include "io/label_components.h"
#include "io/label_table.h"
#include "io/slice_source.h"
#include "job/extract_job.h"
#include "metrics/component_filter.h"
#include "process/decimation.h"
#include "stream/iso_choice.h"
#include "stream/pipeline.h"

namespace isoslab {

struct OpenedInput {
  std::unique_ptr<SliceSource> source;  // cut to the region of interest, when one is set
  std::optional<LatticeBox> roiBox;     // the lattice points the region selected
  SourceOptions options;                // as it was opened (a segmentation's every layer at once)
};

/// Opens settings.inputs, refuses a geometry beyond float32 (unless the space is voxel), hands the
/// readers' notes and warnings to `observer` (nullptr: a rank that does not report) and the
/// warnings to report.warnings, and cuts the source to settings.roi (filling report.roi).
OpenedInput openInput(const ExtractSettings& settings, ExtractObserver* observer, ExtractReport& report);

/// The input opened again (for a second pass), cut to the same box.
std::unique_ptr<SliceSource> reopenInput(const ExtractSettings& settings, const OpenedInput& input);

/// The pipeline's options that the settings give: threads, the memory cap, the sequential cut-off
/// and the ranks (nullptr: one process).
PipelineOptions pipelineOptionsOf(const ExtractSettings& settings, RankGroup* ranks, int threads);

/// The component filter's first pass (settings.components; metrics/component_filter.h): runs the
/// pipeline into a ComponentSink, and on the primary rank (which alone sees the mesh) chooses by
/// `rules` and fills report.componentsJson, componentFilterJson and the pass's seconds. Returns,
/// per part of the first pass, whether it is kept (empty on other ranks).
std::vector<bool> chooseComponents(SliceSource& source, Extractor& extractor, const MeshHeader& header,
                                   const PipelineOptions& options, const ExtractSettings& settings,
                                   const ComponentRules& rules, bool primary, ExtractReport& report);

/// The iso value of a run: settings.iso's number, Otsu's threshold or name, else the input's
/// suggestion (SettingError when it has none). "auto" reads the source to its end, which is then
/// opened again.
IsoChoice chooseIsoValue(const ExtractSettings& settings, OpenedInput& input);

/// report.isoSource, isoRequest, isoNote and isoHistogram from the choice.
void fillIsoReport(const ExtractSettings& settings, const IsoChoice& choice, ExtractReport& report);

/// Why a run wrote no triangles, which would otherwise pass for success (an empty mesh is
/// "closed"): one warning naming the cause, or none when there are triangles.
std::optional<std::string> emptySurfaceWarning(const ExtractSettings& settings, const ExtractReport& report);

/// With `decimate` under 1, when the decimation kept more than 1.2 times the fraction asked for: a
/// warning with the fraction kept, and what limits the collapses (the error bound, the default one
/// or `max_error`'s, and the mesh's shape).
std::optional<std::string> decimationShortWarning(const ExtractReport& report);

/// How far a component seed may lie from a component's bounds: one voxel diagonal.
double seedReach(const ExtractSettings& settings, const VolumeInfo& info);

/// The decimation of the settings, for a voxel edge of `voxelSize` output units, on `threads`
/// threads (its second block in flight may take half of the threads' memory budget).
DecimateOptions decimateOptions(const ExtractSettings& settings, double voxelSize, int threads);

/// Whether the settings decimate (--decimate or --max-error).
bool decimates(const ExtractSettings& settings);

/// The report's decimation part.
ExtractDecimation decimationReport(const ExtractSettings& settings, double voxelSize, const DecimationSink& sink);

/// The smallest and largest value of a source, read to its end (NaN skipped; lo > hi when every
/// value is NaN).
std::array<double, 2> scanValueRange(SliceSource& source);

/// A value of the float slices by its shortest decimal form (999.7, not 999.7000122070312).
double asFloat(double value);

using SlabHook = std::function<void(std::int64_t done, std::int64_t total)>;

/// The label run (job/label_job.cpp): streams the label complex of `input` into each label's
/// writer (a pattern output) or the complex's .ply, and fills `report`. With per-label component
/// rules (settings.components), a first pass (`onComponentSlice`) reads `input`, which is then
/// opened again (reopenInput) for the extraction (`onSlab`). The caller writes the report and
/// commits.
void runLabelExtract(const ExtractSettings& settings, ExtractObserver& observer, OpenedInput input,
                     ExtractReport& report, const SlabHook& onComponentSlice, const SlabHook& onSlab, int threads,
                     const WriterOptions& writing);

/// The labels that a request keeps (nullopt: every label), names resolved through `table` (named
/// `tableName` in messages). In a volume of several layers a value selects its label in every
/// layer, and a name the label it names: `tableKeys` says whether the table's entries are the
/// file's own layered labels. Throws SettingError for a name that the table lacks (naming the
/// nearest) or a range too wide.
std::optional<std::set<std::int32_t>> selectedLabels(const LabelRequest& request, const LabelTable* table,
                                                     const std::string& tableName, int layers, bool tableKeys);

/// The per-label component rules' first pass (settings.components without a seed): reads `labels`
/// (a LabelSource: checked and selected) to its end, finds every label's 6-connected components,
/// chooses by the rules (each label apart; --min-volume against voxels times `voxelVolume`,
/// --min-triangles against two triangles per voxel face), fills report.componentFilterJson and
/// the pass's seconds, and returns the second pass's relabelling (io/label_components.h).
/// Warnings for the labels whose every component the component rules dropped (`changes`), that
/// have no surface (`hasSurface`): one naming the label, or one counting several.
std::vector<std::string> droppedLabelWarnings(const std::map<std::int32_t, LabelChange>& changes,
                                              const std::function<bool(std::int32_t)>& hasSurface,
                                              const std::function<std::string(std::int32_t)>& nameOf);

LabelRelabelling chooseLabelComponents(SliceSource& labels, const std::string& what, const ExtractSettings& settings,
                                       double voxelVolume, const SlabHook& onSlice, ExtractReport& report);

/// A label's file from an output pattern: {name} (made fit for a file name), {label} (the
/// value) and {iso} replaced.
std::string expandPattern(const std::string& pattern, std::int32_t value, const std::string& name,
                          const std::string& iso);

/// Whether `path` is an output for printers (.stl, .3mf, by extension): one whose degenerate
/// triangles are collapsed before writing unless settings.keepDegenerate.
bool printableOutput(const std::string& path);

/// The names of the collapse's counts among a collapsing writer's details(), in their order.
inline constexpr std::array<const char*, 5> kDegenerateDetails{
    "degenerate_triangles_removed", "coincident_vertices_merged", "coincident_points_split",
    "coincident_clusters_separated", "coincident_vertices_moved"};

/// `writer` behind a DegenerateCollapseSink (process/degenerate.h); `remap` for a writer that
/// holds the whole mesh (3MF). Its details() add the collapse's counts (kDegenerateDetails) to the
/// writer's.
std::unique_ptr<MeshFileSink> collapsingWriter(std::unique_ptr<MeshFileSink> writer, bool remap);

/// makeMeshWriter, behind the collapse for a printable output unless settings.keepDegenerate.
std::unique_ptr<MeshFileSink> makeOutputWriter(const std::string& path, const WriterOptions& writing,
                                               const ExtractSettings& settings);

/// Writes `text` to `path` through an AtomicFile (committed with the run's CommitGroup).
void writeReportFile(const std::string& path, const std::string& text);

}  // namespace isoslab
