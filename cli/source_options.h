// The input options that extract and info share: DICOM series choice, raw layout, spacing, NIfTI
// transform. They parse into the readers' SourceOptions (io/open_source.h).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

#include "io/open_source.h"

namespace isoslab::cli {

struct RawArgs {
  std::string series;
  bool strict = false;
  bool skipBad = false;
  int channel = -1;
  std::string niftiXform;  // empty: the sform when sform_code > 0, else the qform
  std::string dims;
  std::string type = "u8";
  std::string endian = "little";
  std::int64_t offset = 0;
  std::string spacing;
};

/// Adds --series, --strict, --skip-bad, --channel, --nifti-xform, --raw-dims, --raw-type,
/// --raw-endian, --raw-offset and --spacing to `cmd`, with their validators.
void addRawOptions(CLI::App* cmd, RawArgs& raw);

/// The options' values, which their validators have checked while parsing.
SourceOptions sourceOptions(const RawArgs& raw);

}  // namespace isoslab::cli
