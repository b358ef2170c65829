# `cpack -G DEB` from the build tree, unpacked (never installed on the
# system) into a fresh root: the package is named and versioned as the
# project, its control file lists its runtime dependencies, and the command
# runs from the unpacked tree.
# Inputs: BUILD_DIR, WORK_DIR, PROJECT_VERSION.
include(${CMAKE_CURRENT_LIST_DIR}/run_checked.cmake)

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
dg_run(COMMAND ${CMAKE_CPACK_COMMAND} -G DEB --config ${BUILD_DIR}/CPackConfig.cmake -B ${WORK_DIR}/out)
file(GLOB debs ${WORK_DIR}/out/*.deb)
list(LENGTH debs deb_count)
if(NOT deb_count EQUAL 1)
  message(FATAL_ERROR "expected one .deb in ${WORK_DIR}/out, found: ${debs}")
endif()

dg_run(OUTPUT fields COMMAND dpkg-deb --field ${debs} Package Version Depends)
message(STATUS "control fields:\n${fields}")
if(NOT fields MATCHES "Package: dynaguide\n" OR NOT fields MATCHES "Version: ${PROJECT_VERSION}\n")
  message(FATAL_ERROR "the package is not dynaguide ${PROJECT_VERSION}:\n${fields}")
endif()
# The libraries the command links most visibly, by their Debian package names.
foreach(dependency libc6 libstdc\\+\\+6 libtbb12 libtbbmalloc2 libhdf5-103-1 libopencv-core406 libyaml-cpp0\\.7 libgmsh4\\.8)
  if(NOT fields MATCHES "Depends: ([^\n]*[ ,])?${dependency}[ ,(\n]")
    message(FATAL_ERROR "the package's Depends lacks ${dependency}:\n${fields}")
  endif()
endforeach()

set(root ${WORK_DIR}/root)
dg_run(COMMAND dpkg-deb --extract ${debs} ${root})
dg_run(OUTPUT help COMMAND ${root}/usr/bin/dynaguide --help)
if(NOT help MATCHES "dynaguide: image-constrained soft-tissue simulation")
  message(FATAL_ERROR "the packaged dynaguide --help printed:\n${help}")
endif()
# The unpacked command meshes through the package's own Gmsh module, found
# beside it, not the build tree's (LD_DEBUG=files lists what the loader loads).
execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_DEBUG=files
    ${root}/usr/bin/dynaguide mesh box --tets 1000 --out ${WORK_DIR}/box.msh
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE loaded)
if(NOT result EQUAL 0 OR NOT loaded MATCHES "calling init: ${root}/usr/lib/[^\n]*dynaguide/dynaguide-gmsh.so\n")
  string(REGEX MATCHALL "file=[^\n]*gmsh[^\n]*" gmsh_lines "${loaded}")
  message(FATAL_ERROR "the packaged dynaguide mesh box gave ${result}, loading: ${gmsh_lines}\n${out}")
endif()
file(GLOB_RECURSE config ${root}/usr/*/dynaguideConfig.cmake)
if(NOT config OR NOT EXISTS ${root}/usr/include/dynaguide/sim/tled_solver.h)
  message(FATAL_ERROR "the package lacks dg::sim's CMake package or headers")
endif()
