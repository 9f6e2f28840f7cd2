# hfrt's run-time modules (base/module.h): shared objects loaded with dlopen when a command first
# needs them, so that their heavy dependency trees stay out of every process's start-up.
#
#   hfrt_add_module(NAME SOURCES a.cpp ... LINK dep ...)
#
# builds libhfrt_NAME.so into ${HFRT_MODULE_BUILD_DIR} (where base/module.cpp looks in a build
# tree) and installs it to <libdir>/hfrt. Only the module's entry point is exported (hidden
# visibility otherwise). The library that uses the module lists it with add_dependencies, so
# building any program that may load it builds it.
include(GNUInstallDirs)
set(HFRT_MODULE_BUILD_DIR "${PROJECT_BINARY_DIR}/modules")

function(hfrt_add_module name)
  cmake_parse_arguments(M "" "" "SOURCES;LINK" ${ARGN})
  set(target hfrt_${name})
  add_library(${target} MODULE ${M_SOURCES})
  set_target_properties(${target} PROPERTIES
    LIBRARY_OUTPUT_DIRECTORY "${HFRT_MODULE_BUILD_DIR}"
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  target_include_directories(${target} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${target} PRIVATE ${M_LINK})
  hfrt_target_defaults(${target})
  install(TARGETS ${target} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/hfrt COMPONENT runtime)
endfunction()
