// Opens any input isoslab understands by its name: a phantom spec, or raw data described by
// RawOptions. Later readers (DICOM, NRRD, ...) are recognised here too.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "io/dicom_series.h"
#include "io/raw_reader.h"
#include "io/slice_source.h"
#include "io/volume_formats.h"

namespace isoslab {

struct SourceOptions {
  /// Set when the user described raw data (--raw-dims and friends).
  std::optional<RawOptions> raw;
  DicomOptions dicom;
  /// Spacing given by the user for inputs that lack one (image stacks).
  std::optional<std::array<double, 3>> spacing;
  /// NIfTI: the transform to take the world frame from (--nifti-xform).
  NiftiXform niftiXform = NiftiXform::kDefault;
};

/// Opens `inputs`: one phantom spec; raw data when options.raw is set; otherwise DICOM (folders,
/// DICOMDIRs, files, or a list of files). Notes for the user (which series was chosen, files
/// skipped, series warnings) are appended to `notes` when given. Throws isoslab::Error naming the
/// input and the problem.
std::unique_ptr<SliceSource> openSource(const std::vector<std::string>& inputs, const SourceOptions& options,
                                        std::vector<std::string>* notes = nullptr);
std::unique_ptr<SliceSource> openSource(const std::string& input, const SourceOptions& options,
                                        std::vector<std::string>* notes = nullptr);

}  // namespace isoslab
