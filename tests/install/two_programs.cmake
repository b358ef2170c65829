# The command's two programs (tools/programs.h) from the build tree:
# `dynaguide` links no video, CT, surface or meshing library; it runs `bench
# sim` itself with no dynaguide-full beside it, and names the missing program
# when asked for a command it hands on; with it beside, --help lists every
# command. Gmsh comes in through its module (io/gmsh_meshing.h) only when a
# command meshes: `mesh box` loads it, `bench sim` on a mesh file does not,
# and a module that cannot be found is named with the places searched.
# dynaguide-full loads TBB's scalable allocator at start (unless built with the
# sanitizers).
# Inputs: DYNAGUIDE (the built front program), GMSH_MODULE (the built module),
# SANITIZE (DG_SANITIZE), WORK_DIR.
include(${CMAKE_CURRENT_LIST_DIR}/run_checked.cmake)

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/alone)

dg_run(OUTPUT dynamic COMMAND readelf --dynamic ${DYNAGUIDE})
string(REGEX MATCHALL "Shared library: \\[[^]]+\\]" needed "${dynamic}")
message(STATUS "dynaguide needs: ${needed}")
if(NOT needed MATCHES "libtbb")
  message(FATAL_ERROR "readelf found no TBB among dynaguide's libraries, so it read the wrong file: ${needed}")
endif()
foreach(heavy opencv ITK itk vtk gdcm ceres glog gmsh)
  if(needed MATCHES "lib${heavy}")
    message(FATAL_ERROR "dynaguide links lib${heavy}*, a library only dynaguide-full's commands need: ${needed}")
  endif()
endforeach()

file(COPY ${DYNAGUIDE} DESTINATION ${WORK_DIR}/alone)
dg_run(OUTPUT help COMMAND ${WORK_DIR}/alone/dynaguide bench sim --help)
if(NOT help MATCHES "--mesh")
  message(FATAL_ERROR "dynaguide bench sim --help, alone, printed:\n${help}")
endif()
execute_process(COMMAND ${WORK_DIR}/alone/dynaguide run --help
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT result EQUAL 1 OR NOT err MATCHES "cannot start dynaguide-full: No such file or directory"
   OR NOT err MATCHES "${WORK_DIR}/alone/dynaguide-full")
  message(FATAL_ERROR "dynaguide run, alone, gave ${result}:\n${out}\n${err}")
endif()

dg_run(OUTPUT help COMMAND ${DYNAGUIDE} --help)
foreach(command sim mesh bench run preop calibrate register eval)
  if(NOT help MATCHES "\n  ${command} ")
    message(FATAL_ERROR "dynaguide --help does not list ${command}:\n${help}")
  endif()
endforeach()

# LD_DEBUG=files makes the dynamic loader list every library a process loads,
# at start or through dlopen, on stderr ("calling init" once it is loaded).
set(mesh ${WORK_DIR}/box.msh)
execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_DEBUG=files
    ${DYNAGUIDE} mesh box --tets 1000 --out ${mesh}
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE loaded)
if(NOT result EQUAL 0 OR NOT EXISTS ${mesh})
  message(FATAL_ERROR "dynaguide mesh box gave ${result}:\n${out}")
endif()
if(NOT loaded MATCHES "calling init: ${GMSH_MODULE}\n" OR NOT loaded MATCHES "calling init: [^\n]*libgmsh")
  string(REGEX MATCHALL "file=[^\n]*gmsh[^\n]*" gmsh_lines "${loaded}")
  message(FATAL_ERROR "dynaguide mesh box did not load ${GMSH_MODULE} and Gmsh through it: ${gmsh_lines}")
endif()

execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_DEBUG=files
    ${DYNAGUIDE} bench sim --mode forward --mesh ${mesh} --threads 1 --repeats 1 --seconds 0.01
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE loaded)
if(NOT result EQUAL 0 OR NOT out MATCHES "M tet-steps/s")
  message(FATAL_ERROR "dynaguide bench sim --mesh gave ${result}:\n${out}")
endif()
if(loaded MATCHES "file=libgmsh" OR loaded MATCHES "dynaguide-gmsh")
  message(FATAL_ERROR "dynaguide bench sim on a mesh file loaded Gmsh, which stepping does not need")
endif()

# dynaguide-full's graph allocates through TBB's scalable allocator, which must
# be in place before the first allocation: loaded at start, not through dlopen.
# A build with the sanitizers keeps their allocator instead.
execute_process(COMMAND ${CMAKE_COMMAND} -E env LD_DEBUG=files ${DYNAGUIDE} run --help
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE loaded)
string(REGEX MATCH "file=[^\n]*libtbbmalloc_proxy[^\n]*" proxy_line "${loaded}")
if(NOT result EQUAL 0 OR NOT out MATCHES "--policy")
  message(FATAL_ERROR "dynaguide run --help gave ${result}:\n${out}")
elseif(SANITIZE AND proxy_line)
  message(FATAL_ERROR "dynaguide-full built with the sanitizers loaded TBB's allocator: ${proxy_line}")
elseif(NOT SANITIZE AND NOT proxy_line MATCHES "needed by ")
  message(FATAL_ERROR "dynaguide-full did not load libtbbmalloc_proxy at start: '${proxy_line}'")
endif()

execute_process(COMMAND ${CMAKE_COMMAND} -E env DG_GMSH_MODULE=${WORK_DIR}/no-such-module.so
    ${DYNAGUIDE} mesh box --tets 1000 --out ${WORK_DIR}/unwritten.msh
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(result EQUAL 0 OR NOT err MATCHES "cannot load the Gmsh module"
   OR NOT err MATCHES "${WORK_DIR}/no-such-module.so: [^\n]*No such file or directory" OR NOT err MATCHES "DG_GMSH_MODULE")
  message(FATAL_ERROR "dynaguide mesh box with a missing module gave ${result}:\n${out}\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env DG_GMSH_MODULE=
    ${DYNAGUIDE} mesh box --tets 1000 --out ${WORK_DIR}/unwritten.msh
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(result EQUAL 0 OR NOT err MATCHES "DG_GMSH_MODULE is set but empty")
  message(FATAL_ERROR "dynaguide mesh box with DG_GMSH_MODULE empty gave ${result}:\n${out}\n${err}")
endif()
