# isoslab_warnings(target): the project's warning and sanitizer flags for one target.
function(isoslab_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wconversion
                                           -Wshadow -Wnon-virtual-dtor)
  if(ISOSLAB_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

if(ISOSLAB_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
endif()
if(ISOSLAB_TSAN)
  if(ISOSLAB_SANITIZE)
    message(FATAL_ERROR "ISOSLAB_TSAN and ISOSLAB_SANITIZE cannot be combined")
  endif()
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()

# The fuzz build instruments every target for coverage (fuzzer-no-link) and for ASan and UBSan;
# only the targets in tests/fuzz/ link libFuzzer itself.
if(ISOSLAB_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "ISOSLAB_FUZZ needs clang: CC=clang CXX=clang++ cmake -DISOSLAB_FUZZ=ON ...")
  endif()
  # extract/mc_table.h builds its case table in a constexpr function that needs more steps than
  # clang's default limit of 2^20.
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer -g -fconstexpr-steps=100000000)
  add_link_options(-fsanitize=address,undefined)
endif()

# isoslab_library(name folder sources...): a static library isoslab_<name>, aliased isoslab::<name>,
# whose headers are included as "<folder>/<file>.h" from the project root.
function(isoslab_library name)
  add_library(isoslab_${name} STATIC ${ARGN})
  add_library(isoslab::${name} ALIAS isoslab_${name})
  target_include_directories(isoslab_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/isoslab>)
  set_target_properties(isoslab_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON
                                                  EXPORT_NAME ${name})
  isoslab_warnings(isoslab_${name})
  target_compile_definitions(isoslab_${name} PRIVATE ISOSLAB_VERSION="${PROJECT_VERSION}")
endfunction()
