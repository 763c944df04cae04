# One place for warnings and per-target settings (KISS-ICP's set_global_target_properties).

# Targets whose own sources build without -Wconversion -Wsign-conversion warnings (GCC and clang; the survey and the
# casts that made them clean: issue 19). A target listed here gets both flags, so a new implicit narrowing or sign
# change in it shows up in the build; a new module opts in once it is clean. Headers of Eigen, PCL, Ceres, the system
# and lcm-gen's generated types come in as SYSTEM includes and are not checked.
set(LOOPD_CONVERSION_CLEAN
  loopd_base loopd_io loopd_pcl_io loopd_sim loopd_opencl loopd_descriptor loopd_segmentation loopd_registration
  loopd_records loopd_verify loopd_correction loopd_pipeline loopd_eval loopd_store
  loopd_lcm loopd_runtime loopd_app loopd)

function(loopd_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unused-parameter)
  if(target IN_LIST LOOPD_CONVERSION_CLEAN)
    target_compile_options(${target} PRIVATE -Wconversion -Wsign-conversion)
  endif()
  target_compile_features(${target} PUBLIC cxx_std_17)
endfunction()
