# What `cmake --install` and `cpack -G DEB` deliver besides the targets' own
# install rules (sim/, tools/): the CMake package for find_package(dynaguide)
# and the Debian package's metadata.
include(CMakePackageConfigHelpers)

set(DG_PACKAGE_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/dynaguide)
# The exported names keep the build tree's: dg::sim.
install(EXPORT dynaguideTargets NAMESPACE dg:: DESTINATION ${DG_PACKAGE_CMAKE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/dynaguideConfig.cmake.in
  ${PROJECT_BINARY_DIR}/dynaguideConfig.cmake
  INSTALL_DESTINATION ${DG_PACKAGE_CMAKE_DIR})
# Before 1.0 a minor version may change the interface.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/dynaguideConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/dynaguideConfig.cmake ${PROJECT_BINARY_DIR}/dynaguideConfigVersion.cmake
  DESTINATION ${DG_PACKAGE_CMAKE_DIR})

# The Debian package: the command, and dg::sim with its CMake package.
set(CPACK_PACKAGE_NAME dynaguide)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "dynaguide developers <dev@dynaguide.invalid>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Image-constrained soft-tissue simulation for surgical guidance")
set(CPACK_PACKAGE_DESCRIPTION
  "The dynaguide command (phantoms, calibration, preoperative steps, tracking, registration, runs, \
evaluation) and the TLED solver library dg::sim with its headers and CMake package (find_package(dynaguide)).")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
# Building against dg::sim needs the headers of its dependencies.
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "libeigen3-dev, libspdlog-dev, libtbb-dev")
find_program(DG_DPKG_SHLIBDEPS dpkg-shlibdeps)
mark_as_advanced(DG_DPKG_SHLIBDEPS)
if(DG_DPKG_SHLIBDEPS)
  # The runtime packages of the shared libraries the command links, with
  # their versions, as Debian's own packages list them.
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
else()
  # The same list on Debian 12 (bookworm), as dpkg-shlibdeps gives it there.
  set(DG_DEBIAN12_DEPENDS
    "libatlas3-base"
    "libc6 (>= 2.35)"
    "libcholmod3 (>= 1:4.5.2)"
    "libcxsparse3 (>= 1:4.5.2)"
    "libfmt9 (>= 9.1.0+ds1)"
    "libgcc-s1 (>= 4.0)"
    "libgmsh4.8 (>= 4.8.4+ds2)"
    "libgoogle-glog0v6 (>= 0.6.0)"
    "libhdf5-103-1"
    "libinsighttoolkit5.2 (>= 5.2.1)"
    "liblapack3 | liblapack.so.3"
    "libopencv-calib3d406 (>= 4.6.0+dfsg)"
    "libopencv-core406 (>= 4.6.0+dfsg)"
    "libopencv-features2d406 (>= 4.6.0+dfsg)"
    "libopencv-imgcodecs406 (>= 4.6.0+dfsg)"
    "libopencv-imgproc406 (>= 4.6.0+dfsg)"
    "libopencv-video406 (>= 4.6.0+dfsg)"
    "libopencv-videoio406 (>= 4.6.0+dfsg)"
    "libspdlog1.10-fmt9"
    "libspqr2 (>= 1:5.12.0+dfsg)"
    "libstdc++6 (>= 12)"
    "libtbb12 (>= 2021.4.0)"
    "libvtk9.1 (>= 9.1.0+really9.1.0+dfsg2)"
    "libyaml-cpp0.7 (>= 0.7.0)")
  list(JOIN DG_DEBIAN12_DEPENDS ", " CPACK_DEBIAN_PACKAGE_DEPENDS)
endif()
include(CPack)
