# Every external dependency is a Debian package installed by scripts/install-deps.sh.
# No FetchContent and no downloads: a missing package is a configure error that names it.

find_package(LLVM 19.1 REQUIRED CONFIG)
message(STATUS "hfrt: LLVM ${LLVM_PACKAGE_VERSION} from ${LLVM_DIR}")
# Two ways to link LLVM, chosen per final target by its HFRT_STATIC_LLVM property
# (hfrt_static_llvm() below):
#  - the shared libLLVM, for the tests, benchmarks and fuzzers: links are fast and small;
#  - LLVM's static component libraries, for what users load (the CLI's run-time module and
#    libhfrt.so): only the components hfrt uses (the host's X86 and NVPTX back ends, ORC, the
#    pass pipelines), their symbols hidden and unused sections dropped. Loading the 120 MB
#    shared libLLVM (all 21 targets, 311k relative relocations, 664 static constructors, z3 and
#    libxml2 with it) took 55-61 ms of every `hfrt render` on the 2-core AMD VM (dlopen timed,
#    bench/README.md "Start-up").
add_library(hfrt_llvm INTERFACE)
target_include_directories(hfrt_llvm SYSTEM INTERFACE ${LLVM_INCLUDE_DIRS})
separate_arguments(_hfrt_llvm_defs NATIVE_COMMAND "${LLVM_DEFINITIONS}")
target_compile_definitions(hfrt_llvm INTERFACE ${_hfrt_llvm_defs})
option(HFRT_STATIC_LLVM "Link LLVM's components statically into the CLI module and libhfrt.so" ON)
llvm_map_components_to_libnames(HFRT_LLVM_STATIC_LIBS
  orcjit passes bitwriter object
  x86codegen x86asmparser x86desc x86info
  nvptxcodegen nvptxdesc nvptxinfo)
set(_hfrt_static "$<BOOL:$<TARGET_PROPERTY:HFRT_STATIC_LLVM>>")
target_link_libraries(hfrt_llvm INTERFACE
  "$<${_hfrt_static}:${HFRT_LLVM_STATIC_LIBS}>" "$<$<NOT:${_hfrt_static}>:LLVM>")

# Marks a final target (a module or shared library) as linking LLVM statically, when
# HFRT_STATIC_LLVM is on: what no code reaches is dropped (--gc-sections; LLVM's archives are
# built with function sections). The target keeps LLVM's symbols local itself: a version
# script (libhfrt.so), or --exclude-libs,ALL for a module that exports nothing of its archives.
function(hfrt_static_llvm target)
  if(HFRT_STATIC_LLVM)
    set_target_properties(${target} PROPERTIES HFRT_STATIC_LLVM ON)
    target_link_options(${target} PRIVATE "LINKER:--gc-sections")
  endif()
endfunction()

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
