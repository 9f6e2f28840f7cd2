# hfrt_target_defaults(TARGET): the warning set and feature level every hfrt target uses.
# Applied per target (no directory-wide flags) so third-party code keeps its own flags.
function(hfrt_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter)
endfunction()
