// The OpenImageIO module (libisoslab_oiio.so), loaded on first use: image stacks read through it
// and PNG images are encoded by it. It is a separate module so that programs that read no image
// pay nothing for OpenImageIO's start-up and its dependencies (see image_stack_oiio.cpp).
#pragma once

namespace isoslab {

/// The address of `symbol` in the module: $ISOSLAB_OIIO_MODULE, then LIBDIR/isoslab/ of an
/// installed tree (found from the file that holds this code and from the program), then the build
/// tree (only for code that runs from the build tree). Throws isoslab::Error saying that `what`
/// needs the module when it cannot be loaded.
void* oiioSymbol(const char* symbol, const char* what);

}  // namespace isoslab
