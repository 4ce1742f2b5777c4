# Thin front end over CMake. `make demo` and `make test` are the README's quick start.
BUILD_DIR ?= build
ASAN_DIR ?= build-asan
JOBS ?= $(shell nproc)
CMAKE_GEN := -G Ninja

.PHONY: all deps build build-asan demo test test-normal test-asan bench clean

all: build

deps:
	@scripts/install-deps.sh

build: deps
	cmake -S . -B $(BUILD_DIR) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DGAUGELOOP_WERROR=ON
	cmake --build $(BUILD_DIR) -j $(JOBS)

build-asan: deps
	cmake -S . -B $(ASAN_DIR) $(CMAKE_GEN) -DCMAKE_BUILD_TYPE=Debug -DGAUGELOOP_SANITIZE=ON -DGAUGELOOP_BENCH=OFF -DGAUGELOOP_WERROR=ON
	cmake --build $(ASAN_DIR) -j $(JOBS)

demo: build
	$(BUILD_DIR)/bin/gaugeloop demo --iterations 3

test-normal: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

test-asan: build-asan
	cd $(ASAN_DIR) && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 ctest --output-on-failure -j $(JOBS)

# Every test, in a normal build and under AddressSanitizer + UndefinedBehaviorSanitizer.
test: test-normal test-asan

# Every benchmark, one after the other (figures: docs/PERFORMANCE.md). Run on a quiet machine.
bench: build
	@for b in $(BUILD_DIR)/bin/*_bench; do echo "== $$b"; $$b || exit 1; done

clean:
	rm -rf $(BUILD_DIR) $(ASAN_DIR)
