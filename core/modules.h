// isoslab's loadable modules, each loaded on first use, so that a run that needs none of them pays
// nothing for their libraries' start-up (docs/design.md, "Loadable modules"):
// - libisoslab_oiio.so: image stacks read and PNG images encoded through OpenImageIO;
// - libisoslab_dicom.so: DICOM series and Segmentation objects read through DCMTK;
// - libisoslab_mpi.so: the ranks of `isoslab extract` under mpirun (cli/mpi_module.cpp);
// - libisoslab_3mf.so: 3MF files written through lib3mf (encode/threemf_module.cpp).
#pragma once

namespace isoslab {

enum class LoadableModule { kOiio, kDicom, kMpi, kThreeMf };

/// The address of `symbol` in `module`: $ISOSLAB_OIIO_MODULE, $ISOSLAB_DICOM_MODULE,
/// $ISOSLAB_MPI_MODULE or $ISOSLAB_3MF_MODULE, then
/// LIBDIR/isoslab/ of an installed tree (found from the file that holds this code and from the
/// program), then the build tree (only for code that runs from the build tree). Throws
/// isoslab::Error saying that `what` needs the module when it cannot be loaded.
void* moduleSymbol(LoadableModule module, const char* symbol, const char* what);

}  // namespace isoslab
