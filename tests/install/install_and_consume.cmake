# `cmake --install` into a fresh prefix; the installed command runs from there
# and writes jobs that call it by its absolute path; a consumer project finds
# the package, links dg::sim, and its result matches Hooke's law.
# Inputs: BUILD_DIR, WORK_DIR, CONSUMER_DIR, GENERATOR, CXX_COMPILER.
include(${CMAKE_CURRENT_LIST_DIR}/run_checked.cmake)

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
dg_run(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})

# Only the solver's archive is installed, not the command's other libraries.
file(GLOB_RECURSE archives RELATIVE ${prefix} ${prefix}/*.a)
list(LENGTH archives archive_count)
if(NOT archive_count EQUAL 1 OR NOT archives MATCHES "/libdg_sim\\.a$")
  message(FATAL_ERROR "expected libdg_sim.a alone, installed: ${archives}")
endif()

set(dynaguide ${prefix}/bin/dynaguide)
dg_run(OUTPUT help COMMAND ${dynaguide} --help)
if(NOT help MATCHES "dynaguide: image-constrained soft-tissue simulation")
  message(FATAL_ERROR "the installed dynaguide --help printed:\n${help}")
endif()

# Jobs written from the prefix start with the binary's own absolute path; an
# --out that a shell would split or unquote reaches the job intact.
set(stability_dir "${WORK_DIR}/stability's cells")
dg_run(COMMAND ${dynaguide} eval stability --quick --emit-jobs ${WORK_DIR}/jobs.txt --out ${stability_dir})
file(STRINGS ${WORK_DIR}/jobs.txt jobs)
list(LENGTH jobs job_count)
file(REAL_PATH ${dynaguide} dynaguide_real)
foreach(job IN LISTS jobs)
  string(FIND "${job}" "${dynaguide_real} eval stability --out '${WORK_DIR}/stability'\\''s cells' " at)
  if(NOT at EQUAL 0)
    message(FATAL_ERROR "a job does not call ${dynaguide_real} with the quoted --out: ${job}")
  endif()
endforeach()
if(job_count LESS 2)
  message(FATAL_ERROR "--emit-jobs wrote ${job_count} jobs")
endif()
# One cell's job (about a second) runs as written, with no dynaguide on PATH.
list(FILTER jobs INCLUDE REGEX " --cell ")
list(GET jobs 0 cell_job)
string(REGEX MATCH "[^ ]+$" cell "${cell_job}")
dg_run(COMMAND ${CMAKE_COMMAND} -E env PATH=/usr/bin:/bin sh -c "${cell_job}")
if(NOT EXISTS "${stability_dir}/cells/${cell}.h5")
  message(FATAL_ERROR "the job `${cell_job}` wrote no ${stability_dir}/cells/${cell}.h5")
endif()

# The consumer: its own configure and build (one source file) against the prefix.
set(consumer_build ${WORK_DIR}/consumer_build)
dg_run(COMMAND ${CMAKE_COMMAND} -S ${CONSUMER_DIR} -B ${consumer_build} -G ${GENERATOR}
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix})
dg_run(COMMAND ${CMAKE_COMMAND} --build ${consumer_build})
dg_run(OUTPUT result COMMAND ${consumer_build}/uniaxial_cube)
message(STATUS "consumer: ${result}")
if(NOT result MATCHES "nominal_stress_pa ([^\n]+)\nhooke_stress_pa ([^\n]+)")
  message(FATAL_ERROR "unexpected consumer output:\n${result}")
endif()
set(stress_pa ${CMAKE_MATCH_1})
# E * strain = 3 kPa * 1e-4; the relaxed cube gives it to 1.5e-4 relative
# (the neo-Hookean material's second-order term and the relaxation's rest).
if(NOT CMAKE_MATCH_2 EQUAL 0.3 OR stress_pa LESS 0.29991 OR stress_pa GREATER 0.30009)
  message(FATAL_ERROR "nominal stress ${stress_pa} Pa, Hooke's law ${CMAKE_MATCH_2} Pa: more than 3e-4 apart")
endif()
