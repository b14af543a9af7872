// DICOM: a single file, or a small series of two or three files in a folder, through openSource()
// as `isoslab extract` opens them (header scan, series choice, then every slice's pixels).
//
// Input: one selector byte, then the file (or the series' files separated by kFileSeparator).
//   bit 0: a series (a folder) rather than one file; bit 1 --strict; bit 2 --skip-bad;
//   bits 3-4: --channel -1, 0, 1, 2.
#include <fmt/format.h>

#include "core/error.h"
#include "fuzz_support.h"
#include "io/open_source.h"

using namespace isoslab;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  const std::uint8_t selector = fuzz::takeByte(in);
  SourceOptions options;
  options.dicom.strict = (selector & 2) != 0;
  options.dicom.skipBad = (selector & 4) != 0;
  options.dicom.channel = ((selector >> 3) & 3) - 1;

  const std::string dir = fuzz::freshDir();
  std::string input;
  if ((selector & 1) == 0) {
    input = dir + "/image.dcm";
    fuzz::writeFile(input, in);
  } else {
    const auto parts = fuzz::splitFiles(in, 3);
    for (std::size_t n = 0; n < parts.size(); ++n) fuzz::writeFile(fmt::format("{}/{}.dcm", dir, n), parts[n]);
    input = dir;
  }
  try {
    std::vector<std::string> notes;
    auto source = openSource(input, options, &notes);
    fuzz::extractAll(*source);
  } catch (const Error&) {
    // A refused input is a normal outcome.
  }
  return 0;
}
