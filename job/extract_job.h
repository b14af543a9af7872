// The extraction run as one call: what `isoslab extract` does, for the program, Python and C++.
//
//   isoslab::ExtractSettings settings;
//   settings.inputs = {"ct/"};
//   settings.iso = isoslab::parseIsoRequest("bone");
//   settings.output = "skull.glb";
//   isoslab::ExtractReport report = isoslab::runExtract(settings);
//
// It opens the input, crops it to the region of interest, chooses the iso value, runs the
// component filter's first pass, then extracts with smoothing, decimation, the measures, the
// preview and the writer in one streaming pass, and commits the mesh and the report together.
#pragma once

#include <cstdint>
#include <string>

#include "job/extract_report.h"
#include "job/extract_settings.h"

namespace isoslab {

/// Where a run stands: `stage` is "components" (the component filter's first pass) or "extract";
/// `done` of `total` slabs of that stage; `fraction` of the whole run, from 0 and rising to 1.
struct ExtractProgress {
  const char* stage = "extract";
  std::int64_t done = 0;
  std::int64_t total = 0;
  double fraction = 0;
};

/// What a caller hears from a run, and how it asks the run to stop. Every call comes from the
/// thread that feeds the sink (the calling thread, or with threads one of the run's), one at a time.
class ExtractObserver {
 public:
  virtual ~ExtractObserver() = default;
  /// After each slab of a pass, and once with fraction 1 when the outputs are committed.
  virtual void progress(const ExtractProgress& /*where*/) {}
  /// A note for the user (which series was read, a clipped region, how the iso value was
  /// chosen); settings are named in backticks (core/error.h).
  virtual void note(const std::string& /*text*/) {}
  /// A warning (a reader's, or an empty surface); also in the report.
  virtual void warning(const std::string& /*text*/) {}
  /// Asked at least once a slab and between stages: true stops the run, which then throws
  /// Interrupted(0) and leaves no output, as a signal does.
  virtual bool stopRequested() { return false; }
  /// How this caller names settings in text that the run writes (the report's warnings and iso
  /// note): the program spells `iso` as --iso. Unchanged by default.
  virtual std::string spell(const std::string& text) const { return text; }
};

/// Runs the job. Throws SettingError for settings that cannot work, Interrupted when stopped (by
/// a signal: core/interrupt.h; or by the observer), and Error for everything else, each with one
/// line that names the input, output or setting. Outputs (the mesh, the report, the preview)
/// appear together or not at all.
ExtractReport runExtract(const ExtractSettings& settings, ExtractObserver& observer);
ExtractReport runExtract(const ExtractSettings& settings);

/// The run's threads when settings.threads is 0: the cores this process may run on, at most 8;
/// with `ranked`, shared among the ranks on this machine.
int defaultExtractThreads(bool ranked);

}  // namespace isoslab
