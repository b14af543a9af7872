#include "io/open_source.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "core/error.h"
#include "io/dicom_seg.h"
#include "io/file_list.h"
#include "io/image_stack.h"
#include "io/phantom.h"
#include "io/volume_formats.h"

namespace isoslab {

std::unique_ptr<SliceSource> openSource(const std::string& input, const SourceOptions& options,
                                        std::vector<std::string>* notes) {
  return openSource(std::vector<std::string>{input}, options, notes);
}

namespace {

std::unique_ptr<SliceSource> openUnchecked(const std::vector<std::string>& inputs, const SourceOptions& options,
                                           std::vector<std::string>* notes) {
  if (inputs.empty()) throw Error("no input given");
  const std::string& input = inputs.front();
  // A FIFO, a device or a socket would be read without end (/dev/zero) or block forever.
  for (const std::string& in : inputs) {
    std::error_code statError;
    const auto status = std::filesystem::status(in, statError);
    if (!statError && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status) &&
        !std::filesystem::is_directory(status)) {
      throw Error(fmt::format("{}: not a regular file or a folder (FIFOs and devices are not read)", in));
    }
  }
  // Phantoms and raw data hold one value per voxel: a channel beyond 0 names nothing.
  if (options.dicom.channel >= 1 && ((inputs.size() == 1 && PhantomSource::isPhantom(input)) || options.raw)) {
    throw Error(fmt::format("`channel`: {} has one value per voxel (channel 0 only)", input));
  }
  if (inputs.size() == 1 && PhantomSource::isPhantom(input)) return PhantomSource::open(input);
  for (const std::string& in : inputs) {
    if (PhantomSource::isPhantom(in)) {
      throw Error(fmt::format("{}: a phantom is a volume by itself: give it as the only input", in));
    }
  }
  if (options.raw) {
    if (inputs.size() > 1) throw Error(fmt::format("{}: raw input takes one file, pattern or folder", inputs[1]));
    return RawReader::open(input, *options.raw);
  }
  if (inputs.size() == 1 && isVolumeFormat(input)) {
    return openVolumeFormat(input, options.dicom.channel, notes, options.niftiXform);
  }
  std::error_code existsError;  // a name the system cannot look up is not there either
  if (isImageStack(inputs) ||
      (inputs.size() == 1 && isImageFile(input) && !std::filesystem::exists(input, existsError))) {
    ImageStackOptions stack;
    stack.channel = options.dicom.channel;
    stack.spacing = options.spacing;
    return openImageStack(inputs, stack, notes);
  }
  std::error_code ec;
  for (const std::string& in : inputs) {
    if (!std::filesystem::exists(in, ec) && !isSlicePattern(in)) {
      throw Error(fmt::format("{}: cannot open: {}", in, std::strerror(ENOENT)));
    }
  }
  // A DICOM Segmentation is a label volume of its own, not an image of a series.
  if (inputs.size() == 1 && isDicomSegmentation(input)) {
    return openDicomSegmentation(input, options.dicom.channel, notes);
  }
  if (std::all_of(inputs.begin(), inputs.end(), [](const std::string& in) { return isDicomInput(in); })) {
    const DicomScan scan = scanDicom(inputs, options.dicom);
    if (scan.series.empty() && scan.segmentations.size() == 1) {
      return openDicomSegmentation(scan.segmentations.front(), options.dicom.channel, notes);
    }
    if (scan.series.empty() && scan.segmentations.size() > 1) {
      throw Error(fmt::format("{}: no DICOM image, but {} DICOM Segmentations ({}, ...); give one of them", input,
                              scan.segmentations.size(), scan.segmentations.front()));
    }
    if (scan.series.empty()) {
      throw Error(fmt::format("{}: no DICOM image found ({} file{} skipped)", input, scan.skipped,
                              scan.skipped == 1 ? "" : "s"));
    }
    std::string chosen;
    const DicomSeries& series = chooseSeries(scan, options.dicom, &chosen);
    if (notes != nullptr) {
      if (!chosen.empty()) notes->push_back(chosen);
      if (scan.skipped > 0) {
        notes->push_back(
            fmt::format("skipped {} {}", scan.skipped,
                        scan.skipped == 1 ? "file that is not a DICOM image" : "files that are not DICOM images"));
      }
      for (const std::string& w : scan.warnings) notes->push_back("warning: " + w);
      for (const std::string& w : series.warnings) notes->push_back("warning: " + w);
      notes->insert(notes->end(), series.notes.begin(), series.notes.end());
    }
    return openDicomSeries(series, options.dicom);
  }
  throw Error(fmt::format("{}: unrecognised input format; for raw data give `raw_dims` X,Y[,Z] and `raw_type`", input));
}

}  // namespace

std::unique_ptr<SliceSource> openSource(const std::vector<std::string>& inputs, const SourceOptions& options,
                                        std::vector<std::string>* notes) {
  auto source = openUnchecked(inputs, options, notes);
  // One geometry check for every reader: NaN, zero or degenerate geometry never reaches a mesh.
  const VolumeInfo& info = source->info();
  validateGeometry(info, info.source.empty() ? inputs.front() : info.source);
  return source;
}

}  // namespace isoslab
