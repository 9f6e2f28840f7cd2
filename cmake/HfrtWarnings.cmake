# hfrt_target_defaults(TARGET): the warning set and feature level every hfrt target uses.
# Applied per target (no directory-wide flags) so third-party code keeps its own flags.
function(hfrt_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  # -Werror=switch: a switch over an enum (above all ir::Op: ir/ir_ops.h, no `default:` in
  # those switches) that misses a case does not compile, so a new op cannot be silently
  # missing from a domain.
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter -Werror=switch)
  # No fused multiply-adds the source does not write: the C++ semantics (ir/scalar_ops.h,
  # ir/trig.h, the interval enclosures) must round as the JIT's unfused operations do. The
  # x86-64 baseline has no FMA, so this only matters for builds with -march flags.
  target_compile_options(${target} PRIVATE -ffp-contract=off)
  # GCC 12 reports false -Wrestrict positives inside libstdc++'s std::string code
  # (GCC bug 105651), fixed in GCC 13.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
endfunction()

# GCC 12 with a precompiled header reports false -Warray-bounds / -Wstringop-overflow positives
# inside libstdc++'s std::string (the same family as GCC bug 105651; not seen without the
# header, fixed in GCC 13): off for the targets that use one (tests, tools/hfrt).
function(hfrt_pch_warnings target)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-array-bounds -Wno-stringop-overflow)
  endif()
endfunction()
