# One place for warnings and per-target settings (KISS-ICP's set_global_target_properties).
function(loopd_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter)
  target_compile_features(${target} PUBLIC cxx_std_17)
endfunction()
