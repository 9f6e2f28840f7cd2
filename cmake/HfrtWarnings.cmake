# hfrt_target_defaults(TARGET): the warning set and feature level every hfrt target uses.
# Applied per target (no directory-wide flags) so third-party code keeps its own flags.
function(hfrt_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter)
  # GCC 12 reports false -Wrestrict positives inside libstdc++'s std::string code
  # (GCC bug 105651), fixed in GCC 13.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
endfunction()
