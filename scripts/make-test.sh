#!/usr/bin/env bash
# The test phases of `make test` after the normal build (Makefile: test), arranged so that the
# two cores stay busy:
#   1. the AddressSanitizer build at nice 19, beside the normal build's tests but the real-time
#      ones (run-parallel);
#   2. the real-time tests (run-serial: ctest label `serial`, about 200 s mostly waiting on a
#      simulated spindle) at normal priority, beside the AddressSanitizer tests at nice 10: the
#      real-time tests get a core whenever they want one (the scheduler weighs nice 10 at 110
#      against nice 0's 1024), the sanitizer tests get the rest. The real-time tests run in the
#      normal build directory, the sanitizer tests in theirs, so no two ctest runs share a
#      Testing/ directory.
# The ThreadSanitizer phase is `make test-tsan`, apart (.ci/run runs it after `make test`).
# A build's output goes to <build dir>/background-build.log, the real-time tests' to
# <build dir>/serial-tests.log; each is printed in full if it failed (the tests' log always).
# Every test run's output is also kept in <build dir>/<phase>-tests.log, and the script ends with
# the failed tests of every phase and each one's output, so that the last lines of a long log
# (all a CI page may show) say what failed. Every phase runs to its end; the script fails if any
# build or test run failed.
set -uo pipefail
: "${MAKE:=make}" "${BUILD_DIR:=build}" "${ASAN_DIR:=build-asan}" "${JOBS:=2}" "${TEST_JOBS:=4}"

# build_beside DIR [cmake --build arguments...]: starts the build in the background; its pid in BUILD_PID.
build_beside() {
  local dir="$1"
  shift
  echo "== building ${dir} beside the tests at nice 19 (${dir}/background-build.log)"
  nice -n 19 cmake --build "${dir}" -j "${JOBS}" "$@" >"${dir}/background-build.log" 2>&1 &
  BUILD_PID=$!
}

# finish_build DIR: waits for the background build; prints its log and fails if it failed.
finish_build() {
  local dir="$1"
  if wait "${BUILD_PID}"; then
    echo "== ${dir} built"
    return 0
  fi
  echo "== the build in ${dir} FAILED; its log:"
  cat "${dir}/background-build.log"
  return 1
}

# run_tests NICENESS PHASE DIR [make arguments...]: runs `make run-PHASE` at that niceness, its
# output to the terminal and to DIR/PHASE-tests.log; fails if the tests failed.
run_tests() {
  local niceness="$1" phase="$2" dir="$3"
  shift 3
  nice -n "${niceness}" "${MAKE}" --no-print-directory "run-${phase}" "$@" 2>&1 | tee "${dir}/${phase}-tests.log"
}

# failed_tests LOG: each failed test of a ctest log with the output ctest printed for it (up to
# 60 lines each).
failed_tests() {
  awk '
    / Test +#[0-9]+: / { inside = ($0 ~ /\*\*\*(Failed|Timeout|Exception)|Not Run/); lines = 0 }
    /^ *Start +[0-9]+: / { inside = 0 }
    /^[0-9]+% tests passed/ { inside = 0 }
    inside && lines < 60 { print; ++lines }
  ' "$1"
}

status=0
build_beside "${ASAN_DIR}"
run_tests 0 parallel "${BUILD_DIR}" BUILD_DIR="${BUILD_DIR}" TEST_JOBS="${TEST_JOBS}" || status=1
asan_built=0
finish_build "${ASAN_DIR}" && asan_built=1 || status=1

echo "== the real-time tests at normal priority, beside the rest (${BUILD_DIR}/serial-tests.log)"
"${MAKE}" --no-print-directory run-serial BUILD_DIR="${BUILD_DIR}" >"${BUILD_DIR}/serial-tests.log" 2>&1 &
serial_pid=$!

if [ "${asan_built}" -eq 1 ]; then
  run_tests 10 asan "${ASAN_DIR}" ASAN_DIR="${ASAN_DIR}" TEST_JOBS="${TEST_JOBS}" || status=1
fi

echo "== waiting for the real-time tests"
serial_status=0
wait "${serial_pid}" || serial_status=1
echo "== the real-time tests' log:"
cat "${BUILD_DIR}/serial-tests.log"
[ "${serial_status}" -eq 0 ] || { echo "== the real-time tests FAILED"; status=1; }

if [ "${status}" -ne 0 ]; then
  echo "== what failed"
  for log in "${BUILD_DIR}/parallel-tests.log" "${BUILD_DIR}/serial-tests.log" "${ASAN_DIR}/asan-tests.log"; do
    [ -f "${log}" ] || continue
    found="$(failed_tests "${log}")"
    [ -n "${found}" ] && printf '%s:\n%s\n' "${log}" "${found}"
  done
  echo "== make test FAILED (the failed tests above; a failed build's log earlier)"
fi
exit "${status}"
