// Text on images through OpenImageIO's FreeType rendering, inside the OpenImageIO module: the
// labels of the figures suite. The pixels themselves are encoded by libpng (image_writer.cpp).
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <cstdint>
#include <string>
#include <vector>

#include "io/image_writer.h"

extern "C" __attribute__((visibility("default"))) bool isoslab_draw_labels(
    int width, int height, std::uint8_t* rgb, const std::vector<isoslab::ImageLabel>* labels, std::string* error) {
  try {
    OIIO::ImageBuf buffer(OIIO::ImageSpec(width, height, 3, OIIO::TypeDesc::UINT8), rgb);
    const float black[3] = {0, 0, 0};
    for (const isoslab::ImageLabel& label : *labels) {
      if (!OIIO::ImageBufAlgo::render_text(buffer, label.x, label.y, label.text, label.size, "DejaVuSans", black)) {
        *error = "cannot draw the label '" + label.text + "' (is fonts-dejavu-core installed?): " + buffer.geterror();
        return false;
      }
    }
    return true;
  } catch (const std::exception& e) {
    *error = std::string("cannot draw the labels: ") + e.what();
  }
  return false;
}
