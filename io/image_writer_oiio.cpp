// PNG encoding through OpenImageIO, into memory (an IOProxy), inside the OpenImageIO module; the
// caller writes the bytes with AtomicFile, so that an image is complete or absent like every output.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cstdint>
#include <string>
#include <vector>

extern "C" __attribute__((visibility("default"))) bool isoslab_encode_png(int width, int height,
                                                                          const std::uint8_t* rgb,
                                                                          std::vector<unsigned char>* out,
                                                                          std::string* error) {
  try {
    OIIO::Filesystem::IOVecOutput proxy(*out);
    auto png = OIIO::ImageOutput::create("png");
    if (!png) {
      *error = "OpenImageIO has no PNG writer: " + OIIO::geterror();
      return false;
    }
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("Software", "isoslab");
    OIIO::Filesystem::IOProxy* pointer = &proxy;
    spec.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &pointer);
    if (!png->open("image.png", spec) || !png->write_image(OIIO::TypeDesc::UINT8, rgb) || !png->close()) {
      *error = "OpenImageIO could not encode the PNG: " + png->geterror();
      return false;
    }
    return true;
  } catch (const std::exception& e) {
    *error = std::string("OpenImageIO could not encode the PNG: ") + e.what();
  }
  return false;
}
