// NRRD, MetaImage and NIfTI headers with their data, through openSource() as `isoslab extract`
// opens them.
//
// Input: one selector byte, then the files separated by kFileSeparator.
//   selector % 8: 0 .nrrd, 1 .mha, 2 .nii, 3 .nii.gz, 4 .nhdr, 5 .mhd, 6 .hdr, 7 .nii (again)
//   selector / 8 % 4: --channel -1, 0, 1, 2;  / 32 % 3: --nifti-xform default, sform, qform
// The first file is the header (or the whole file); detached formats get the next files as
// v.raw, v1.raw, v2.raw (NIfTI's .hdr: v.img), the names the seeds' headers use.
#include <fmt/format.h>

#include "core/error.h"
#include "fuzz_support.h"
#include "io/open_source.h"

using namespace isoslab;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  const std::uint8_t selector = fuzz::takeByte(in);
  static const char* const kExtensions[] = {".nrrd", ".mha", ".nii", ".nii.gz", ".nhdr", ".mhd", ".hdr", ".nii"};
  const std::string ext = kExtensions[selector % 8];
  SourceOptions options;
  options.dicom.channel = (selector / 8) % 4 - 1;
  options.niftiXform = static_cast<NiftiXform>((selector / 32) % 3);

  const std::string dir = fuzz::freshDir();
  const std::string input = dir + "/v" + ext;
  const auto parts = fuzz::splitFiles(in, 4);
  fuzz::writeFile(input, parts[0]);
  for (std::size_t n = 1; n < parts.size(); ++n) {
    const std::string name = ext == ".hdr" && n == 1 ? "v.img" : n == 1 ? "v.raw" : fmt::format("v{}.raw", n - 1);
    fuzz::writeFile(dir + "/" + name, parts[n]);
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
