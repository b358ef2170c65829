# The command's two programs (tools/programs.h) from the build tree:
# `dynaguide` links no video, CT or surface library; it runs `bench sim`
# itself with no dynaguide-full beside it, and names the missing program
# when asked for a command it hands on; with it beside, --help lists every
# command.
# Inputs: DYNAGUIDE (the built front program), WORK_DIR.
include(${CMAKE_CURRENT_LIST_DIR}/run_checked.cmake)

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/alone)

dg_run(OUTPUT dynamic COMMAND readelf --dynamic ${DYNAGUIDE})
string(REGEX MATCHALL "Shared library: \\[[^]]+\\]" needed "${dynamic}")
message(STATUS "dynaguide needs: ${needed}")
if(NOT needed MATCHES "libgmsh" OR NOT needed MATCHES "libtbb")
  message(FATAL_ERROR "readelf found no Gmsh or TBB among dynaguide's libraries, so it read the wrong file: ${needed}")
endif()
foreach(heavy opencv ITK itk vtk gdcm ceres glog)
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
