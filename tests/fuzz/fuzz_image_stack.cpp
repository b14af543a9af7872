// Image stacks through OpenImageIO: two or three PNG or TIFF files as the slices of a stack, or one
// (multi-page) TIFF, through openSource() as `isoslab extract` opens them.
//
// Input: one selector byte, then the images separated by kFileSeparator.
//   bit 0: .tif rather than .png; bits 1-2: 0 a folder, 1 a list of files, 2 a printf pattern,
//   3 the first image alone (a multi-page TIFF); bits 3-4: --channel -1, 0, 1, 2;
//   bit 5: --spacing 1,1,2 given.
#include <fmt/format.h>

#include "core/error.h"
#include "fuzz_support.h"
#include "io/open_source.h"

using namespace isoslab;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  const std::uint8_t selector = fuzz::takeByte(in);
  const std::string ext = (selector & 1) != 0 ? ".tif" : ".png";
  const int layout = (selector >> 1) & 3;
  SourceOptions options;
  options.dicom.channel = ((selector >> 3) & 3) - 1;
  if ((selector & 32) != 0) options.spacing = std::array<double, 3>{1, 1, 2};

  const std::string dir = fuzz::freshDir();
  const auto parts = fuzz::splitFiles(in, layout == 3 ? 1 : 3);
  std::vector<std::string> inputs;
  for (std::size_t n = 0; n < parts.size(); ++n) {
    inputs.push_back(fmt::format("{}/slice{:02d}{}", dir, n, ext));
    fuzz::writeFile(inputs.back(), parts[n]);
  }
  if (layout == 0) inputs = {dir};
  if (layout == 2) inputs = {dir + "/slice%02d" + ext};
  try {
    std::vector<std::string> notes;
    auto source = openSource(inputs, options, &notes);
    fuzz::extractAll(*source);
  } catch (const Error&) {
    // A refused input is a normal outcome.
  }
  return 0;
}
