# Registers one ctest test per GoogleTest suite of a test executable: run after the executable
# is built (tests/CMakeLists.txt, gaugeloop_add_test), it lists the executable's tests and
# writes CTEST_FILE, which ctest includes.
#
#   cmake -D TEST_EXECUTABLE=<path> -D CTEST_FILE=<path> -D WORKING_DIR=<dir> -D SERIAL=<TRUE|FALSE>
#         -P discover_suites.cmake
#
# A suite's tests run in one process (`--gtest_filter=Suite.*`), the suites apart: under
# AddressSanitizer a process per test case cost the storage tests half their CPU time in
# starting and ending processes (docs/building.md). The ctest name is the suite's, with `.*`: `GrindingLoopTest.*`.
# Its timeout grows with its number of tests (300 s and 60 s a test, at most 1800 s).

foreach(var TEST_EXECUTABLE CTEST_FILE WORKING_DIR SERIAL)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "discover_suites.cmake: ${var} is not set")
  endif()
endforeach()

execute_process(
  COMMAND "${TEST_EXECUTABLE}" --gtest_list_tests
  WORKING_DIRECTORY "${WORKING_DIR}"
  TIMEOUT 60
  OUTPUT_VARIABLE listing
  ERROR_VARIABLE listing_errors
  RESULT_VARIABLE listed)
if(NOT listed EQUAL 0)
  message(FATAL_ERROR "${TEST_EXECUTABLE} --gtest_list_tests failed (${listed}):\n${listing}${listing_errors}")
endif()

# The listing: a suite's line starts in the first column and ends its name with a dot (a typed
# suite adds "  # TypeParam = ..."); each test of it follows, indented.
string(REPLACE ";" "\\;" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")
set(suites "")
set(suite "")
foreach(line IN LISTS lines)
  if(line MATCHES "^([^ #][^ ]*)\\.( |$)")
    set(suite "${CMAKE_MATCH_1}")
    list(APPEND suites "${suite}")
    set(count_${suite} 0)
  elseif(line MATCHES "^  [^ ]" AND NOT suite STREQUAL "")
    math(EXPR count_${suite} "${count_${suite}} + 1")
  endif()
endforeach()

set(script "# Written by tests/discover_suites.cmake from ${TEST_EXECUTABLE} --gtest_list_tests\n")
foreach(suite IN LISTS suites)
  math(EXPR timeout "300 + 60 * ${count_${suite}}")
  if(timeout GREATER 1800)
    set(timeout 1800)
  endif()
  set(name "${suite}.*")
  string(APPEND script
    "add_test([==[${name}]==] \"${TEST_EXECUTABLE}\" [==[--gtest_filter=${suite}.*]==])\n"
    "set_tests_properties([==[${name}]==] PROPERTIES WORKING_DIRECTORY \"${WORKING_DIR}\" TIMEOUT ${timeout}")
  if(SERIAL)
    string(APPEND script " RUN_SERIAL TRUE LABELS serial")
  endif()
  string(APPEND script ")\n")
endforeach()
file(WRITE "${CTEST_FILE}" "${script}")
