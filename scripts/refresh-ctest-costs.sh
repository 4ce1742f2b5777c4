#!/usr/bin/env bash
# Writes tests/ctest-costs.txt, the seconds each test suite took, from the cost data ctest kept
# in a build directory after a run (by default build-asan/, after `make test-asan`): a new build
# directory starts from it, so that its first ctest run starts the longest suites first
# (tests/CMakeLists.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
dir="${1:-build-asan}"
data="${dir}/Testing/Temporary/CTestCostData.txt"
[ -f "${data}" ] || { echo "refresh-ctest-costs: no ${data}: run the tests in ${dir} first" >&2; exit 2; }
known="$(mktemp)"
trap 'rm -f "${known}"' EXIT
ctest --test-dir "${dir}" -N | sed -n 's/^ *Test *#[0-9]*: //p' | sort > "${known}"
# Each registered test's cost, longest first; ctest's list of failed tests (after ---) left out.
awk 'NR == FNR { known[$0] = 1; next } /^---/ { exit } ($1 in known) { printf "%s 1 %.1f\n", $1, $3 }' \
  "${known}" "${data}" | sort -k3 -rn > tests/ctest-costs.txt
echo "---" >> tests/ctest-costs.txt
echo "refresh-ctest-costs: $(($(wc -l < tests/ctest-costs.txt) - 1)) suites written to tests/ctest-costs.txt"
