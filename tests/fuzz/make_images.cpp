// Seed images for the image-stack fuzz target (scripts/make_fuzz_corpus.sh): writes the slices of
// an isoslab input (a small phantom) with OpenImageIO, one file per slice, or all slices as pages
// of one TIFF.
//
//   fuzz_make_images INPUT OUT_PATTERN TYPE CHANNELS [multipage]
//     OUT_PATTERN: a fmt pattern of the slice index ("dir/s{}.png") or, with multipage, one .tif path
//     TYPE: uint8, uint16 or float
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/error.h"
#include "io/open_source.h"

int main(int argc, char** argv) {
  if (argc != 5 && argc != 6) {
    std::fprintf(stderr, "usage: fuzz_make_images INPUT OUT_PATTERN uint8|uint16|float CHANNELS [multipage]\n");
    return 2;
  }
  try {
    auto source = isoslab::openSource(argv[1], {});
    const isoslab::VolumeInfo& info = source->info();
    const std::string pattern = argv[2];
    const OIIO::TypeDesc type = std::strcmp(argv[3], "float") == 0    ? OIIO::TypeDesc::FLOAT
                                : std::strcmp(argv[3], "uint16") == 0 ? OIIO::TypeDesc::UINT16
                                                                      : OIIO::TypeDesc::UINT8;
    const int channels = std::stoi(argv[4]);
    const bool multipage = argc == 6;
    std::vector<float> slice(static_cast<std::size_t>(info.sliceVoxels()));
    std::unique_ptr<OIIO::ImageOutput> out;
    for (int k = 0; source->readSlice(slice); ++k) {
      std::vector<float> px;
      for (float v : slice) px.insert(px.end(), static_cast<std::size_t>(channels), std::round(v));
      OIIO::ImageSpec spec(static_cast<int>(info.dims[0]), static_cast<int>(info.dims[1]), channels, type);
      const std::string path = multipage ? pattern : fmt::format(fmt::runtime(pattern), k);
      if (!multipage || k == 0) {
        out = OIIO::ImageOutput::create(path);
        if (!out || !out->open(path, spec)) throw isoslab::Error(path + ": " + OIIO::geterror());
      } else if (!out->open(path, spec, OIIO::ImageOutput::AppendSubimage)) {
        throw isoslab::Error(path + ": " + out->geterror());
      }
      bool ok = false;
      if (type == OIIO::TypeDesc::FLOAT) {
        ok = out->write_image(OIIO::TypeDesc::FLOAT, px.data());
      } else if (type == OIIO::TypeDesc::UINT16) {
        std::vector<std::uint16_t> p16(px.begin(), px.end());
        ok = out->write_image(OIIO::TypeDesc::UINT16, p16.data());
      } else {
        std::vector<std::uint8_t> p8(px.begin(), px.end());
        ok = out->write_image(OIIO::TypeDesc::UINT8, p8.data());
      }
      if (!ok) throw isoslab::Error(path + ": " + out->geterror());
      if (!multipage) out->close();
    }
    if (multipage && out) out->close();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_make_images: %s\n", e.what());
    return 1;
  }
  return 0;
}
