#include "io/image_writer.h"

#include <fmt/format.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/oiio_module.h"

namespace isoslab {

void writePng(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb) {
  if (width <= 0 || height <= 0 ||
      rgb.size() != 3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw Error(fmt::format("{}: an image of {}x{} pixels needs {} bytes, not {}", path, width, height,
                            3LL * width * height, rgb.size()));
  }
  using Encode = bool (*)(int, int, const std::uint8_t*, std::vector<unsigned char>*, std::string*);
  const auto encode = reinterpret_cast<Encode>(oiioSymbol("isoslab_encode_png", "PNG images"));
  std::vector<unsigned char> bytes;
  std::string error;
  if (!encode(width, height, rgb.data(), &bytes, &error)) throw Error(fmt::format("{}: {}", path, error));
  AtomicFile out(path);
  out.write(bytes.data(), bytes.size());
  out.commit();
}

}  // namespace isoslab
