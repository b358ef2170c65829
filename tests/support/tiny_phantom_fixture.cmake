# CTest fixture `tiny_phantom` (tests/CMakeLists.txt): the tiny phantom scene,
# generated once per test run into DIR by the dynaguide command at DYNAGUIDE.
# The tests that require it read it through DG_TINY_PHANTOM_DIR and copy it
# (tests/support/tiny_phantom.cc): nothing writes into DIR but this script.
file(REMOVE_RECURSE "${DIR}")
execute_process(
  COMMAND "${DYNAGUIDE}" phantom --preset tiny --out "${DIR}" --quiet
  RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "dynaguide phantom --preset tiny failed (${result})")
endif()
