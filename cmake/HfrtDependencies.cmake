# Every external dependency is a Debian package installed by scripts/install-deps.sh.
# No FetchContent and no downloads: a missing package is a configure error that names it.

find_package(LLVM 19.1 REQUIRED CONFIG)
message(STATUS "hfrt: LLVM ${LLVM_PACKAGE_VERSION} from ${LLVM_DIR}")
# The shared libLLVM keeps link times and binary sizes small.
add_library(hfrt_llvm INTERFACE)
target_include_directories(hfrt_llvm SYSTEM INTERFACE ${LLVM_INCLUDE_DIRS})
separate_arguments(_hfrt_llvm_defs NATIVE_COMMAND "${LLVM_DEFINITIONS}")
target_compile_definitions(hfrt_llvm INTERFACE ${_hfrt_llvm_defs})
target_link_libraries(hfrt_llvm INTERFACE LLVM)

find_package(CLI11 CONFIG QUIET)
if(NOT TARGET CLI11::CLI11)
  add_library(CLI11::CLI11 INTERFACE IMPORTED)
endif()

find_package(TBB REQUIRED CONFIG)
# Scene files (scene/): toml++ 3 from libtomlplusplus-dev, whose CMake package imports the
# shared libtomlplusplus (TOML_HEADER_ONLY=0).
find_package(tomlplusplus 3 REQUIRED CONFIG)
find_package(Threads REQUIRED)
# PNG files are written with zlib directly (render/png_writer.h), not through OpenImageIO.
find_package(ZLIB REQUIRED)

find_package(PkgConfig REQUIRED)
pkg_check_modules(OIIO REQUIRED IMPORTED_TARGET OpenImageIO)
pkg_check_modules(LIBEDIT REQUIRED IMPORTED_TARGET libedit)

if(HFRT_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
if(HFRT_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()

# Where the shared corpus lives (CI and developers have shared/ beside the checkout).
set(HFRT_CORPUS_DIR "${PROJECT_SOURCE_DIR}/../shared/corpus" CACHE PATH "HyperFun corpus folder")
