#!/usr/bin/env bash
# Installs every Debian package gaugeloop needs to build, test and benchmark.
# This is the only place packages are named. It installs only what is missing, so it is
# cheap to run before every build. Needs root (or sudo) when something is missing.
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build make pkgconf
  ccache             # the compiler cache (CMakeLists.txt): a rebuild of what was built before is a cache hit
  clang libclang-rt-dev llvm  # the sanitizer builds' compiler, its sanitizer runtimes, llvm-symbolizer for their reports
  lld                # the linker of the developers' and CI's builds (GAUGELOOP_LLD): a third of GNU ld's time
  # libraries the product links
  libmodbus-dev      # gauge link and simulator (Modbus TCP/RTU)
  libeigen3-dev      # spline, kinematics, FFT
  libsqlite3-dev     # run history
  libcli11-dev       # command line
  libtomlplusplus-dev  # part and config files
  nlohmann-json3-dev   # --json output
  libspdlog-dev libfmt-dev  # logging and formatting
  libmstch-dev       # Mustache rendering of NC program templates (brings libboost-dev headers)
  libcpp-httplib-dev # the HTTP API of `gaugeloop serve` (built with OpenSSL: HTTPS)
  libsystemd-dev     # sd_notify: readiness and the watchdog under systemd
  libcairo2-dev      # the cam report and trend charts: one drawing code for PDF, SVG and PNG
  libmosquitto-dev   # plant messages to an MQTT broker (store and forward from the outbox)
  libpqxx-dev        # the plant's central history in PostgreSQL (brings libpq-dev)
  fonts-dejavu-core  # the font the reports are drawn with
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  sqlite3            # the CLI users query the database with; tests use it too
  mbpoll             # independent Modbus client: tests read the simulator with it
  socat              # pseudo-terminal pairs for Modbus RTU tests
  python3            # runs tests/layering's include check (and the pymodbus peer)
  python3-pymodbus   # an independent Modbus server: tests read a gauge served by it
  python3-serial python3-serial-asyncio  # pymodbus imports both even for TCP; only Recommended, so named here
  mosquitto mosquitto-clients  # a real MQTT broker (and mosquitto_passwd) for the plant tests
  postgresql-15      # a real PostgreSQL server the plant tests start in a temporary directory
  openssl            # self-signed certificates for the HTTPS and broker TLS tests; `gaugeloop token new` needs none
  curl               # an independent HTTP client: tests talk to the service with it
  strace             # syscall fault injection (--inject): tests/fault kills and fails a push at every step
  locales            # a decimal-comma locale, to test that output ignores the C locale
  chromium chromium-driver python3-selenium  # a headless browser: tests/web drives the service's pages
  librsvg2-bin       # rsvg-convert: view a `gaugeloop runs plot` SVG as PNG; not needed to build or test
)

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

generate_test_locale() {
  # de_DE.UTF-8 writes 1,5: tests check that tables and the database never do.
  if ! locale -a 2>/dev/null | grep -qi '^de_DE\.utf-\?8$'; then
    echo "install-deps: generating locale de_DE.UTF-8 for the tests"
    $sudo localedef -i de_DE -f UTF-8 de_DE.UTF-8
  fi
}

sudo=""
if [[ $(id -u) -ne 0 ]] && command -v sudo >/dev/null 2>&1; then sudo="sudo"; fi

if [[ ${#missing[@]} -eq 0 ]]; then
  generate_test_locale
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
if [[ $(id -u) -ne 0 && -z "$sudo" ]]; then
  echo "install-deps: missing packages and not root: run as root: apt-get install ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
generate_test_locale
