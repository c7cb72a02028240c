# The two commands of the README: `make run` and `make test`. Both install what is missing first.
BUILD_DIR ?= build
# the default scenario: the three-star spiral of the seed §VI-A (tracked, evaluated, plotted)
SCENARIO ?= configs/regression/three_star_spiral.yaml
CMAKE_FLAGS ?=
# tests run side by side, one per core: none asserts a wall-clock duration, and each run has its own ports,
# shared memory and run folder (README: Tests)
TEST_JOBS ?= $(shell nproc)

.PHONY: deps configure build run test nightly bench clean

deps:
	@tools/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) > /dev/null

build: configure
	@cmake --build $(BUILD_DIR)

run: build
	@$(BUILD_DIR)/bin/iapsim run $(SCENARIO)

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure --timeout 600 --parallel $(TEST_JOBS)

# flights too slow for `make test` (they render): configs/regression/slow, both profiles
nightly: build
	@$(BUILD_DIR)/bin/iapsim regress configs/regression/slow --out $(BUILD_DIR)/regress-slow

bench: build
	@$(BUILD_DIR)/bin/iapsim bench all

clean:
	rm -rf $(BUILD_DIR)
