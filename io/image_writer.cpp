#include "io/image_writer.h"

#include <fmt/format.h>
#include <png.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "core/modules.h"

namespace isoslab {

void writePng(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb,
              const std::vector<ImageLabel>& labels) {
  if (width <= 0 || height <= 0 ||
      rgb.size() != 3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw Error(fmt::format("{}: an image of {}x{} pixels needs {} bytes, not {}", path, width, height,
                            3LL * width * height, rgb.size()));
  }
  // Labels are drawn by OpenImageIO's FreeType text (the module, loaded only for them); the
  // pixels are encoded by libpng, which costs no memory to speak of (loading OpenImageIO maps
  // about 120 MiB of libraries, which a preview on a small machine must not pay).
  std::vector<std::uint8_t> pixels = rgb;
  if (!labels.empty()) {
    using Draw = bool (*)(int, int, std::uint8_t*, const std::vector<ImageLabel>*, std::string*);
    const auto draw =
        reinterpret_cast<Draw>(moduleSymbol(LoadableModule::kOiio, "isoslab_draw_labels", "labelled images"));
    std::string error;
    if (!draw(width, height, pixels.data(), &labels, &error)) throw Error(fmt::format("{}: {}", path, error));
  }
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, pixels.data(), 0, nullptr)) {
    throw Error(fmt::format("{}: libpng cannot encode the image: {}", path, image.message));
  }
  std::vector<unsigned char> bytes(size);
  if (!png_image_write_to_memory(&image, bytes.data(), &size, 0, pixels.data(), 0, nullptr)) {
    throw Error(fmt::format("{}: libpng cannot encode the image: {}", path, image.message));
  }
  bytes.resize(size);
  throwIfInterrupted();  // encoding a large image takes a while
  AtomicFile out(path);
  out.write(bytes.data(), bytes.size());
  out.commit();
}

}  // namespace isoslab
