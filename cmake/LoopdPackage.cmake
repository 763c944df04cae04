# Debian packages with CPack's DEB generator (scripts/package builds and checks them; packaging/deb holds the sources).
#   loopd      components runtime (programs, loopd-spy, loopd_types.jar, the example config) and system (below)
#   loopd-dev  components dev (headers, static libraries, CMake package) and dev-doc
#   loopd-ros  components ros (bag2lcm: it links Debian's ROS 1 bag libraries) and ros-doc (its man page, copyright,
#              changelog); made only where bag2lcm is built (tools/bag2lcm/CMakeLists.txt), so that installing the daemon
#              never pulls ROS libraries
# system, dev-doc and ros-doc are EXCLUDE_FROM_ALL: a plain `cmake --install` never writes /etc/loopd or
# /lib/systemd/system on a developer's machine; only cpack installs them, into its staging directory (CPACK_SET_DESTDIR,
# prefix /usr).
set(loopd_deb_src ${CMAKE_SOURCE_DIR}/packaging/deb)
set(loopd_deb_out ${CMAKE_BINARY_DIR}/package-files)
set(LOOPD_PACKAGE_CONTACT "loopd maintainers <maintainers@users.noreply.h-seed-2365b61f.example>" CACHE STRING "Maintainer of the .deb")

# /etc/loopd/loopd.yaml: loopd.example.yaml with map.path /var/lib/loopd/map.db, regenerated when the example changes.
# Built with everything (cheap) so that the ctest below always checks the current file.
add_custom_command(
  OUTPUT ${loopd_deb_out}/loopd.yaml
  COMMAND ${CMAKE_COMMAND} -DIN=${CMAKE_SOURCE_DIR}/daemon/loopd.example.yaml -DOUT=${loopd_deb_out}/loopd.yaml
          -DMAP_PATH=/var/lib/loopd/map.db -P ${loopd_deb_src}/make-config.cmake
  DEPENDS ${CMAKE_SOURCE_DIR}/daemon/loopd.example.yaml ${loopd_deb_src}/make-config.cmake
  COMMENT "Package config /etc/loopd/loopd.yaml from loopd.example.yaml")
add_custom_target(loopd_package_config ALL DEPENDS ${loopd_deb_out}/loopd.yaml)
if(LOOPD_BUILD_TESTS)
  add_test(NAME package_config_matches_example
           COMMAND bash ${loopd_deb_src}/check-config $<TARGET_FILE:loopd> ${CMAKE_SOURCE_DIR}/daemon/loopd.example.yaml
                   ${loopd_deb_out}/loopd.yaml)
  set_tests_properties(package_config_matches_example PROPERTIES LABELS package TIMEOUT 60)
endif()

# Man pages from each program's --help (packaging/deb/help-to-man), built only for the package (target loopd_package_files).
# loopd_man_pages go into loopd (component system), loopd_ros_man_pages into loopd-ros (ros-doc): each page goes where its
# program goes (loopd_add_tool's COMPONENT).
get_property(loopd_tool_targets GLOBAL PROPERTY LOOPD_TOOL_TARGETS)
set(loopd_man_pages "")
set(loopd_ros_man_pages "")
foreach(program loopd ${loopd_tool_targets})
  set(page ${loopd_deb_out}/man/${program}.1.gz)
  add_custom_command(
    OUTPUT ${page}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${loopd_deb_out}/man
    COMMAND ${loopd_deb_src}/help-to-man $<TARGET_FILE:${program}> ${program} ${PROJECT_VERSION} ${page}
    DEPENDS ${program} ${loopd_deb_src}/help-to-man
    COMMENT "Man page ${program}.1 from ${program} --help")
  get_property(component GLOBAL PROPERTY LOOPD_TOOL_COMPONENT_${program})
  if(component STREQUAL ros)
    list(APPEND loopd_ros_man_pages ${page})
  elseif(NOT component OR component STREQUAL runtime)
    list(APPEND loopd_man_pages ${page})
  else()
    message(FATAL_ERROR "${program}: install component ${component} has no package (cmake/LoopdPackage.cmake)")
  endif()
endforeach()
# loopd-spy finds loopd_types.jar next to itself (../share/java) before it parses --help: run a copy laid out that way.
if(TARGET loopd_types_jar)
  set(spy_tree ${loopd_deb_out}/spy-tree)
  add_custom_command(
    OUTPUT ${loopd_deb_out}/man/loopd-spy.1.gz
    COMMAND ${CMAKE_COMMAND} -E make_directory ${spy_tree}/bin ${spy_tree}/share/java ${loopd_deb_out}/man
    COMMAND ${CMAKE_COMMAND} -E copy ${CMAKE_SOURCE_DIR}/scripts/loopd-spy ${spy_tree}/bin/loopd-spy
    COMMAND ${CMAKE_COMMAND} -E copy ${LOOPD_TYPES_JAR} ${spy_tree}/share/java/loopd_types.jar
    COMMAND ${loopd_deb_src}/help-to-man ${spy_tree}/bin/loopd-spy loopd-spy ${PROJECT_VERSION} ${loopd_deb_out}/man/loopd-spy.1.gz
    DEPENDS loopd_types_jar ${CMAKE_SOURCE_DIR}/scripts/loopd-spy ${loopd_deb_src}/help-to-man
    COMMENT "Man page loopd-spy.1 from loopd-spy --help")
  list(APPEND loopd_man_pages ${loopd_deb_out}/man/loopd-spy.1.gz)
endif()

# /usr/share/doc/<package>: copyright and the gzip'd changelog (native package: changelog.gz).
configure_file(${loopd_deb_src}/changelog.in ${loopd_deb_out}/changelog @ONLY)
add_custom_command(
  OUTPUT ${loopd_deb_out}/changelog.gz
  COMMAND gzip -9nkf ${loopd_deb_out}/changelog
  DEPENDS ${loopd_deb_out}/changelog
  COMMENT "changelog.gz")

# Everything the packages hold, built: scripts/package builds this target, then runs cpack.
add_custom_target(loopd_package_files DEPENDS ${loopd_man_pages} ${loopd_ros_man_pages} ${loopd_deb_out}/changelog.gz)
add_dependencies(loopd_package_files loopd loopd_package_config ${loopd_tool_targets} ${loopd_export_targets})
if(TARGET loopd_types_jar)
  add_dependencies(loopd_package_files loopd_types_jar)
endif()

install(FILES ${loopd_deb_out}/loopd.yaml DESTINATION /etc/loopd COMPONENT system EXCLUDE_FROM_ALL)
# The unit comes from daemon/systemd (issue 18); until it exists the package has none.
if(EXISTS ${CMAKE_SOURCE_DIR}/daemon/systemd/loopd.service)
  install(FILES ${CMAKE_SOURCE_DIR}/daemon/systemd/loopd.service DESTINATION /lib/systemd/system COMPONENT system EXCLUDE_FROM_ALL)
endif()
install(FILES ${loopd_man_pages} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT system EXCLUDE_FROM_ALL)
install(FILES ${loopd_deb_src}/copyright ${loopd_deb_out}/changelog.gz DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/loopd
        COMPONENT system EXCLUDE_FROM_ALL)
install(FILES ${loopd_deb_src}/copyright ${loopd_deb_out}/changelog.gz DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/loopd-dev
        COMPONENT dev-doc EXCLUDE_FROM_ALL)
install(FILES ${loopd_deb_src}/lintian-overrides DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/lintian/overrides RENAME loopd
        COMPONENT system EXCLUDE_FROM_ALL)
if(loopd_ros_man_pages)
  install(FILES ${loopd_ros_man_pages} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT ros-doc EXCLUDE_FROM_ALL)
  install(FILES ${loopd_deb_src}/copyright ${loopd_deb_out}/changelog.gz DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/loopd-ros
          COMPONENT ros-doc EXCLUDE_FROM_ALL)
endif()
# The packages this configuration makes, one a line: scripts/package expects exactly these from cpack.
set(loopd_packages loopd loopd-dev)
if(loopd_ros_man_pages)
  list(APPEND loopd_packages loopd-ros)
endif()
list(JOIN loopd_packages "\n" loopd_packages_text)
file(WRITE ${loopd_deb_out}/packages "${loopd_packages_text}\n")

# CPack: one package per group, named as the group. Descriptions: CPack indents the lines after the summary.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME loopd)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${LOOPD_PACKAGE_CONTACT}")
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime system dev dev-doc)
set(CPACK_COMPONENT_RUNTIME_GROUP loopd)
set(CPACK_COMPONENT_SYSTEM_GROUP loopd)
set(CPACK_COMPONENT_DEV_GROUP loopd-dev)
set(CPACK_COMPONENT_DEV-DOC_GROUP loopd-dev)
if(loopd_ros_man_pages)
  list(APPEND CPACK_COMPONENTS_ALL ros ros-doc)
  set(CPACK_COMPONENT_ROS_GROUP loopd-ros)
  set(CPACK_COMPONENT_ROS-DOC_GROUP loopd-ros)
endif()
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)  # Depends from dpkg-shlibdeps on the binaries as linked
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

set(CPACK_DEBIAN_LOOPD_PACKAGE_NAME loopd)
set(CPACK_DEBIAN_LOOPD_PACKAGE_SECTION science)
# adduser: postinst. libjs-three, libjs-chart.js: the live page (--http) loads them from /usr/share/javascript.
set(CPACK_DEBIAN_LOOPD_PACKAGE_DEPENDS "adduser, libjs-three, libjs-chart.js")  # merged with the shlibdeps list
# loopd-spy is a shell script starting Java's lcm-spy with loopd_types.jar: not a dependency of the daemon.
set(CPACK_DEBIAN_LOOPD_PACKAGE_RECOMMENDS "default-jre-headless | java-runtime-headless, liblcm-java, libjchart2d-java")
set(CPACK_DEBIAN_LOOPD_PACKAGE_SUGGESTS "opencl-icd")  # descriptor.backend opencl; without one loopd uses the CPU
set(CPACK_DEBIAN_LOOPD_PACKAGE_CONTROL_EXTRA ${loopd_deb_src}/postinst ${loopd_deb_src}/prerm ${loopd_deb_src}/postrm
                                             ${loopd_deb_src}/conffiles)
set(CPACK_DEBIAN_LOOPD_DESCRIPTION "lidar loop-closure daemon for LCM
loopd listens for lidar scans and odometry poses on an LCM bus, detects and
verifies loop closures (M2DP descriptor, plane-based 4PCS, GICP and a
cluster consistency check) and publishes loop events and the corrected
trajectory. Its map (keyframes, loops, corrections) is kept in SQLite so a
restart resumes.
.
This package holds the daemon with its systemd unit (loopd.service, user
loopd, configuration /etc/loopd/loopd.yaml, map /var/lib/loopd/map.db), the
command-line tools (simulation, evaluation, map inspection, benchmarks),
loopd-spy and the Java message types for lcm-spy. bag2lcm, which links ROS
libraries, is in loopd-ros.")

set(CPACK_DEBIAN_LOOPD-DEV_PACKAGE_NAME loopd-dev)
set(CPACK_DEBIAN_LOOPD-DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_LOOPD-DEV_PACKAGE_DEPENDS
    "liblcm-dev, libeigen3-dev, libceres-dev, libpcl-dev, ocl-icd-opencl-dev, libsqlite3-dev, libzstd-dev, libpqxx-dev, pkg-config")
set(CPACK_DEBIAN_LOOPD-DEV_DESCRIPTION "lidar loop-closure library of loopd (development files)
The static libraries of loopd's pipeline (descriptors, segmentation,
registration, verification, loop correction, map store), their headers,
the C++ headers of loopd's LCM message types and the CMake package:
find_package(loopd) and link loopd::loopd_library.")

# loopd-ros: bag2lcm alone; Depends only what dpkg-shlibdeps finds on it (the ROS 1 bag libraries, liblcm1, the C++
# runtime). Nothing of the loopd package: loopd's libraries are linked in statically and bag2lcm reads no file of it. Not
# even Recommends: apt would install the daemon, which enables and starts a service, on a machine that only converts
# bags. Suggests, as its logs are for loopd --replay, loopd-eval and loopd-compare.
set(CPACK_DEBIAN_LOOPD-ROS_PACKAGE_NAME loopd-ros)
set(CPACK_DEBIAN_LOOPD-ROS_PACKAGE_SECTION science)
set(CPACK_DEBIAN_LOOPD-ROS_PACKAGE_SUGGESTS "loopd")
set(CPACK_DEBIAN_LOOPD-ROS_DESCRIPTION "ROS 1 bag converter for the lidar loop-closure daemon loopd
bag2lcm turns a ROS 1 bag (rosbag record) into an LCM drive log that loopd
--replay, loopd-eval and loopd-compare read: sensor_msgs/PointCloud2 scans,
odometry from nav_msgs/Odometry or from /tf, optional ground truth. It reads
the bag with Debian's ROS 1 libraries and needs no ROS installation and no
roscore.
.
It is packaged apart from loopd so that the daemon's package does not
depend on ROS libraries.")
include(CPack)
