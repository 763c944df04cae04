# cmake --install: binaries, headers (library + generated LCM types), loopd_types.jar, and a package config
# so that find_package(loopd) works from another project.
include(CMakePackageConfigHelpers)
set(loopd_export_targets loopd_lcmtypes loopd_library ${LOOPD_MODULES})
if(TARGET loopd_kernels)
  list(APPEND loopd_export_targets loopd_kernels)
endif()
install(TARGETS ${loopd_export_targets} EXPORT loopdTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT loopdTargets NAMESPACE loopd:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/loopd)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/loopdConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/loopdConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/loopd)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/loopdConfigVersion.cmake COMPATIBILITY SameMajorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/loopdConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/loopdConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/loopd)
