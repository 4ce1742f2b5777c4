# Thin front end over CMake. `make demo` and `make test` are the README's quick start.
# Build directories, what each builds and what it costs: docs/building.md.
BUILD_DIR ?= build
ASAN_DIR ?= build-asan
TSAN_DIR ?= build-tsan
JOBS ?= $(shell nproc)
# Tests at a time (ctest -j): twice the cores. Most tests spend most of their time waiting on a
# simulated spindle, a socket or a child process, so twice as many keep the cores busy; they
# hold on a loaded machine (docs/building.md). The SERIAL real-time tests run alone regardless.
TEST_JOBS ?= $(shell echo $$((2 * $(JOBS))))
CMAKE_GEN := -G Ninja
# The compiler of the sanitizer builds: Clang compiles them in about 60 % of GCC's time
# (docs/building.md, "What `make test` costs"); the normal build, what users run, keeps the
# system's compiler (GCC on Debian).
SANITIZER_CXX ?= clang++

# The tests that time live polling against a real clock (SERIAL: about 245 s run alone). They
# run in the normal build only: under a sanitizer's slowdown they test the machine, not the code.
REALTIME_TESTS := ^(LiveLink\.|PymodbusPeer\.|SimulatorFaults/LiveOutageTest\.)
# A plant of grinders, a broker and PostgreSQL as processes, through outages (examples/plant):
# what it tests of our code under the sanitizers the plant tests test in-process; normal build only.
# The pages in headless Chromium (tests/web) likewise: their endpoints run in-process in tests/service.
# The push under strace's injected faults (tests/fault) too: LeakSanitizer does not run under
# ptrace, and tests/integration cuts the push's steps in-process.
PROCESS_TESTS := ^(PlantRun|WebPages|PushFaults)\.
# The tests of the service's threads (HTTP server, PLC trigger and handshake, the run) and of
# the guard every thread starts through, the systemd watchdog's, the outbox sender's and the
# central sync's: the ones ThreadSanitizer runs.
TSAN_TESTS := ^(GuardedThread|IntegrityWatchTest|OutboxSenderTest|CentralSyncerTest|PlantServiceTest|PlantServeTest|PlcHandshakeTest|PlcServiceWords|PlcServiceTest|HttpApiTest|ServiceTest|ServiceStateTest|ServiceConfigFile|ServiceWatchdog|ServiceNotifyEnv)\.
TSAN_TARGETS := core_test plant_mqtt_test plant_mqtt_service_test plant_central_test service_unit_test service_integration_test packaging_test gaugeloop

.PHONY: all deps configure configure-asan configure-tsan build build-asan build-tsan demo check test test-normal test-asan test-tsan run-normal run-serial run-parallel run-asan run-tsan package test-package bench clean

all: build

deps:
	@scripts/install-deps.sh

# Release: what users run, and asserts off, as they are for users; -Werror for CI and developers.
configure: deps
	cmake -S . -B $(BUILD_DIR) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=Release -DGAUGELOOP_WERROR=ON -DGAUGELOOP_LLD=ON

configure-asan: deps
	cmake -S . -B $(ASAN_DIR) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=$(SANITIZER_CXX) -DGAUGELOOP_SANITIZE=ON -DGAUGELOOP_BENCH=OFF -DGAUGELOOP_WERROR=ON -DGAUGELOOP_LLD=ON

configure-tsan: deps
	cmake -S . -B $(TSAN_DIR) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=$(SANITIZER_CXX) -DGAUGELOOP_TSAN=ON -DGAUGELOOP_BENCH=OFF -DGAUGELOOP_WERROR=ON -DGAUGELOOP_LLD=ON

# Everything: the binary, every test and every benchmark.
build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

build-asan: configure-asan
	cmake --build $(ASAN_DIR) -j $(JOBS)

# Only what the ThreadSanitizer run needs.
build-tsan: configure-tsan
	cmake --build $(TSAN_DIR) -j $(JOBS) --target $(TSAN_TARGETS)

demo: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target gaugeloop
	$(BUILD_DIR)/bin/gaugeloop demo --iterations 3

# Each phase is its build, then its run (run-*: the tests of a build already built).
test-normal: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target gaugeloop_tests
	$(MAKE) --no-print-directory run-normal

test-asan: build-asan
	$(MAKE) --no-print-directory run-asan

test-tsan: build-tsan
	$(MAKE) --no-print-directory run-tsan

# The SERIAL real-time tests (ctest label `serial`) first, so that no other test runs beside
# them; then the others $(TEST_JOBS) at a time, the longest first (ctest's cost data in
# $(BUILD_DIR)/Testing, which a new build directory starts from tests/ctest-costs.txt). A ctest
# test is a GoogleTest suite, `Suite.*`, its tests in one process (tests/discover_suites.cmake).
# Both ctest runs run to the end; the phase fails if either failed. run-serial and run-parallel
# are its two halves: `make test` runs them apart (scripts/make-test.sh).
run-normal:
	$(MAKE) --no-print-directory run-serial; serial=$$?; \
	  $(MAKE) --no-print-directory run-parallel; rest=$$?; [ $$serial -eq 0 ] && [ $$rest -eq 0 ]

run-serial:
	cd $(BUILD_DIR) && ctest --output-on-failure -L serial

run-parallel:
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(TEST_JOBS) -LE serial

# quarantine_size_mb=16 (the default is 256): a freed block still waits for 16 MB of later frees
# before its memory is used again, and a test process no longer touches up to 256 MB of fresh
# pages on the way (about a fifth of the AddressSanitizer tests' CPU: docs/building.md).
run-asan:
	cd $(ASAN_DIR) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:quarantine_size_mb=16 LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 ctest --output-on-failure -j $(TEST_JOBS) -E '$(REALTIME_TESTS)|$(PROCESS_TESTS)'

run-tsan:
	cd $(TSAN_DIR) && TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1:suppressions=$(CURDIR)/tests/tsan.supp \
	  ctest --output-on-failure -j $(TEST_JOBS) --no-tests=error -R '$(TSAN_TESTS)'

# The edit-compile-test loop: the normal build's tests only, without the real-time and process
# tests (about 150 s of clock on two cores). TESTS=regex narrows it to the suites it matches
# (`TESTS=GrindingLoop`); one test case: build/bin/<layer>_test --gtest_filter=Suite.Case.
TESTS ?= .
check: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target gaugeloop_tests
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(TEST_JOBS) -R '$(TESTS)' -E '$(REALTIME_TESTS)|$(PROCESS_TESTS)'

# The Debian package, from the Release build: only the binary is built (test-normal has built
# it already), then cpack: $(BUILD_DIR)/gaugeloop_<version>_<arch>.deb.
package: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target gaugeloop
	rm -f $(BUILD_DIR)/gaugeloop_*.deb
	cd $(BUILD_DIR) && cpack -G DEB

# Installs the package on this machine with dpkg -i (as root: the CI), checks it, then removes
# and purges it. Refuses a machine where gaugeloop is installed (packaging/test_package.sh).
test-package: package
	packaging/test_package.sh $(BUILD_DIR)

# Every test in a normal build and under AddressSanitizer + UndefinedBehaviorSanitizer (less the
# real-time ones); the package installed. What runs beside what (scripts/make-test.sh): the
# AddressSanitizer build at nice 19 beside the normal build's other tests; then the real-time
# tests at normal priority beside the AddressSanitizer tests at nice 10, so that the real-time
# tests get the CPU whenever they want it and the rest the core they leave. The service's threads
# under ThreadSanitizer are `make test-tsan`, a build of their own that `.ci/run` runs after this
# one: in `make test` they took a third build's time, and the 20 minutes (docs/building.md).
test: configure configure-asan
	cmake --build $(BUILD_DIR) -j $(JOBS) --target gaugeloop_tests
	MAKE="$(MAKE)" BUILD_DIR="$(BUILD_DIR)" ASAN_DIR="$(ASAN_DIR)" JOBS="$(JOBS)" TEST_JOBS="$(TEST_JOBS)" \
	  scripts/make-test.sh
	$(MAKE) --no-print-directory test-package

# Every benchmark, one after the other (figures: docs/PERFORMANCE.md). Run on a quiet machine.
bench: build
	@for b in $(BUILD_DIR)/bin/*_bench; do echo "== $$b"; $$b || exit 1; done

clean:
	rm -rf $(BUILD_DIR) $(ASAN_DIR) $(TSAN_DIR)
