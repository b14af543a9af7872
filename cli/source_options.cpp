#include "cli/source_options.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "cli/arguments.h"
#include "core/voxel_type.h"

namespace isoslab::cli {

void addRawOptions(CLI::App* cmd, RawArgs& raw) {
  cmd->add_option("--series", raw.series,
                  "DICOM: the series to read, by SeriesInstanceUID or index (default: the largest)")
      ->group("DICOM input");
  cmd->add_flag("--strict", raw.strict, "DICOM: treat series warnings (a slice may be missing, duplicates) as errors")
      ->group("DICOM input");
  cmd->add_flag("--skip-bad", raw.skipBad, "DICOM: skip corrupt or unreadable files with a warning")
      ->group("DICOM input");
  cmd->add_option("--channel", raw.channel,
                  "Colour or multi-component input (DICOM, image stacks, NRRD, MetaImage): the channel to use, from 0; "
                  "a segmentation's layer (.seg.nrrd, DICOM SEG), which otherwise all go in one pass")
      ->check(integerIn(-1, std::numeric_limits<int>::max(), " (-1: none)"))
      ->group("DICOM input");
  cmd->add_option("--nifti-xform", raw.niftiXform,
                  "NIfTI: the world transform, sform or qform (default: the sform when sform_code > 0, else the "
                  "qform)")
      ->check(CLI::IsMember({"sform", "qform"}))
      ->group("DICOM input");
  cmd->add_option("--raw-dims", raw.dims, "Raw input: lattice points X,Y,Z (Z may be left out for per-slice files)")
      ->check(numberList([](const std::vector<double>& dims) -> std::string {
        if (dims.size() != 2 && dims.size() != 3) return "needs X,Y or X,Y,Z";
        for (double d : dims) {
          if (d != std::floor(d) || d < -9.0e18 || d > 9.0e18) return "must hold whole numbers";
        }
        return {};
      }))
      ->group("Raw input");
  cmd->add_option("--raw-type", raw.type, "Raw input: voxel type u8 i8 u16 i16 u32 i32 f32 f64")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            return parseVoxelType(value)
                       ? std::string()
                       : fmt::format("unknown voxel type '{}' (use u8 i8 u16 i16 u32 i32 f32 f64)", value);
          },
          ""))
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--raw-endian", raw.endian, "Raw input: byte order, little or big")
      ->transform(oneOf("byte order", {"little", "big"}))
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--raw-offset", raw.offset, "Raw input: header bytes to skip in each file")
      ->check(integerIn(0, std::numeric_limits<std::int64_t>::max()))
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--spacing", raw.spacing, "Voxel spacing sx,sy,sz (raw input and image stacks; default 1,1,1)")
      ->check(numberList([](const std::vector<double>& s) -> std::string {
        if (s.size() != 3) return "needs three values";
        return s[0] > 0 && s[1] > 0 && s[2] > 0 ? "" : "needs three positive values";
      }))
      ->group("Raw input");
}

SourceOptions sourceOptions(const RawArgs& raw) {
  SourceOptions options;
  options.dicom.series = raw.series;
  options.dicom.strict = raw.strict;
  options.dicom.skipBad = raw.skipBad;
  options.dicom.channel = raw.channel;
  if (raw.niftiXform == "sform") options.niftiXform = NiftiXform::kSform;
  if (raw.niftiXform == "qform") options.niftiXform = NiftiXform::kQform;
  std::optional<std::array<double, 3>> spacing;
  if (!raw.spacing.empty()) {
    const auto s = parseList(raw.spacing, "--spacing");
    spacing = std::array<double, 3>{s.at(0), s.at(1), s.at(2)};
  }
  if (raw.dims.empty()) {
    options.spacing = spacing;
    return options;
  }
  RawOptions r;
  const auto dims = parseList(raw.dims, "--raw-dims");
  for (std::size_t a = 0; a < dims.size() && a < 3; ++a) r.dims[a] = static_cast<std::int64_t>(dims[a]);
  r.type = parseVoxelType(raw.type).value();
  r.byteOrder = raw.endian == "big" ? ByteOrder::kBig : ByteOrder::kLittle;
  r.headerBytes = raw.offset;
  if (spacing) r.spacing = *spacing;
  options.raw = r;
  return options;
}

}  // namespace isoslab::cli
