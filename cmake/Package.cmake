# The man page and the Debian package (issue 22): `cpack -G DEB` in the build folder makes
# isoslab_<version>_amd64.deb from the install rules, with the dependencies dpkg-shlibdeps finds.
# Build with -DCMAKE_INSTALL_PREFIX=/usr so that the libraries go to Debian's multiarch folder
# (scripts/package_test.sh does, and checks the package with lintian).

set(ISOSLAB_MAINTAINER "isoslab developers <isoslab@isoslab.invalid>" CACHE STRING
  "The Maintainer of the Debian package")
# The newest entry of cmake/debian/changelog must be this version. Its date is the man page's
# date, so that the same version gives the same bytes.
file(STRINGS ${PROJECT_SOURCE_DIR}/cmake/debian/changelog changelog_top LIMIT_COUNT 1)
if(NOT changelog_top MATCHES "^isoslab \\(${PROJECT_VERSION}\\) ")
  message(FATAL_ERROR "cmake/debian/changelog: its newest entry is '${changelog_top}', not version ${PROJECT_VERSION}")
endif()
file(STRINGS ${PROJECT_SOURCE_DIR}/cmake/debian/changelog changelog_date REGEX "^ -- " LIMIT_COUNT 1)
string(REGEX REPLACE "^ -- .*>  " "" changelog_date "${changelog_date}")
execute_process(COMMAND date -u -d "${changelog_date}" +%s OUTPUT_VARIABLE ISOSLAB_RELEASE_EPOCH
                OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake/debian/changelog: cannot read the date '${changelog_date}'")
endif()

# The man page: help2man from --help and --version, with every command's own --help appended
# (cmake/ManPage.cmake). Without help2man, no man page is installed.
find_program(HELP2MAN help2man)
if(HELP2MAN AND NOT ISOSLAB_SANITIZE AND NOT ISOSLAB_TSAN AND NOT ISOSLAB_FUZZ)
  add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/isoslab.1.gz
    COMMAND ${CMAKE_COMMAND} -DPROGRAM=$<TARGET_FILE:isoslab> -DHELP2MAN=${HELP2MAN}
            -DEPOCH=${ISOSLAB_RELEASE_EPOCH} -DOUT=${CMAKE_CURRENT_BINARY_DIR}/isoslab.1
            -P ${PROJECT_SOURCE_DIR}/cmake/ManPage.cmake
    DEPENDS isoslab ${PROJECT_SOURCE_DIR}/cmake/ManPage.cmake
    COMMENT "Writing the man page isoslab.1 (help2man)" VERBATIM)
  add_custom_target(isoslab_man ALL DEPENDS ${CMAKE_CURRENT_BINARY_DIR}/isoslab.1.gz)
  install(FILES ${CMAKE_CURRENT_BINARY_DIR}/isoslab.1.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
endif()

# Debian's documentation files: the copyright, and the changelog compressed as Debian wants it.
set(doc_dir ${CMAKE_INSTALL_DATAROOTDIR}/doc/isoslab)
add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/debian/changelog.gz
  COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_CURRENT_BINARY_DIR}/debian
  COMMAND sh -c "gzip -9n -c \"$0\" > \"$1\"" ${PROJECT_SOURCE_DIR}/cmake/debian/changelog
          ${CMAKE_CURRENT_BINARY_DIR}/debian/changelog.gz
  DEPENDS ${PROJECT_SOURCE_DIR}/cmake/debian/changelog VERBATIM)
add_custom_target(isoslab_changelog ALL DEPENDS ${CMAKE_CURRENT_BINARY_DIR}/debian/changelog.gz)
install(FILES ${PROJECT_SOURCE_DIR}/cmake/debian/copyright ${CMAKE_CURRENT_BINARY_DIR}/debian/changelog.gz
        DESTINATION ${doc_dir})

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME isoslab)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${ISOSLAB_MAINTAINER}")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
# Installed with DESTDIR, so that the rules that run when installing (the Python package's folder,
# the .pc file's prefix) see the prefix /usr.
set(CPACK_SET_DESTDIR ON)
if(NOT CMAKE_INSTALL_PREFIX MATCHES "^/usr/?$")
  message(STATUS "isoslab: configured for ${CMAKE_INSTALL_PREFIX}; cpack -G DEB wants -DCMAKE_INSTALL_PREFIX=/usr "
                 "(Debian's multiarch library folder)")
endif()
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "streaming iso-surface extraction from volumetric scans")
# Debian wraps nothing: lines under 80 characters.
set(CPACK_PACKAGE_DESCRIPTION
  "isoslab turns CT, MR and industrial CT volumes (DICOM, NIfTI, NRRD,
MetaImage, raw, image stacks) into closed, oriented iso-surface meshes in one
pass that holds a few slices at a time. It offers Marching Cubes and Marching
Tetrahedra (5, 6, 12 and 24 tetrahedra per cube), and writes Draco-compressed
glTF, PLY, STL and OBJ.
.
This package holds the isoslab program, the C++20 library libisoslab.so with
its headers, CMake and pkg-config files, the OpenImageIO module for image
stacks, and the Python package.")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# A shlibs file for libisoslab.so, and the ldconfig trigger a public shared library needs (as
# dh_makeshlibs writes it). CPack would instead call ldconfig from postinst and postrm unless the
# package brings its own, which therefore only say that there is nothing to do. prerm removes the
# byte code Python wrote beside the package.
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY ">=")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${PROJECT_SOURCE_DIR}/cmake/debian/triggers
  ${PROJECT_SOURCE_DIR}/cmake/debian/postinst ${PROJECT_SOURCE_DIR}/cmake/debian/prerm
  ${PROJECT_SOURCE_DIR}/cmake/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
# The Python package's own needs (its extension module links no Python library).
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "python3, python3-numpy")
set(CPACK_STRIP_FILES ON)
include(CPack)
