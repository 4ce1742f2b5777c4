#!/usr/bin/env bash
# The test phases of `make test` after the normal build (Makefile: test). Each sanitizer build
# runs in the background at nice 19 while the phase before it runs its tests, so that a core
# those tests leave idle builds instead of waiting; then that phase's tests run. The builds'
# output goes to <build dir>/background-build.log, printed in full if the build fails.
# Every phase runs to its end; the script fails if any build or test run failed.
set -uo pipefail
: "${MAKE:=make}" "${BUILD_DIR:=build}" "${ASAN_DIR:=build-asan}" "${TSAN_DIR:=build-tsan}" "${JOBS:=2}" "${TEST_JOBS:=4}"
: "${TSAN_TARGETS:?set by the Makefile: what the ThreadSanitizer build builds}"

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

status=0
build_beside "${ASAN_DIR}"
"${MAKE}" --no-print-directory run-normal BUILD_DIR="${BUILD_DIR}" TEST_JOBS="${TEST_JOBS}" || status=1
if finish_build "${ASAN_DIR}"; then
  # shellcheck disable=SC2086 # the targets are a list
  build_beside "${TSAN_DIR}" --target ${TSAN_TARGETS}
  "${MAKE}" --no-print-directory run-asan ASAN_DIR="${ASAN_DIR}" TEST_JOBS="${TEST_JOBS}" || status=1
  if finish_build "${TSAN_DIR}"; then
    "${MAKE}" --no-print-directory run-tsan TSAN_DIR="${TSAN_DIR}" TEST_JOBS="${TEST_JOBS}" || status=1
  else
    status=1
  fi
else
  status=1
fi
exit "${status}"
