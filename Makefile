# One entry point for a fresh clone. `make demo` and `make test` need nothing done by hand:
# they create .venv, install the Python dependencies, build all C (CMake) and the cffi modules.
# The development install is editable and compiles nothing (-C wheel.cmake=false); `make cmake`
# builds the C once, in build/: the C tests, build/bin/hil_stub and the cffi modules, which it
# also puts next to their package's sources (HIL_PYTHON_INPLACE), where the editable install
# imports them from. After editing C, `make build` rebuilds what changed. `pip install .` or
# `pip wheel .` (scikit-build-core) builds the same CMake project into a self-contained wheel.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
BUILD   := build
SCENARIO ?= bench/scenarios/gong_g2_500rpm.toml

.PHONY: all build native cmake firmware-cm4 test test-c test-py sanitize demo perf clean fuzz fuzz-ci wheel

all: build

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip
	$(VPY) -m pip install -q -e '.[test]' -C wheel.cmake=false
	touch $@

# the cffi modules need the venv's Python (with cffi) to generate their C
CMAKE_PY := -DHIL_PYTHON_MODULES=ON -DPython_EXECUTABLE=$(abspath $(VPY))

cmake: $(STAMP)
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo $(CMAKE_PY) -DHIL_PYTHON_INPLACE=ON >/dev/null
	cmake --build $(BUILD) -j2

# the cffi modules alone (kept for habit: `make cmake` builds them with everything else)
native: cmake

# The MCAP project's readers (@mcap/core, @mcap/support: what Foxglove reads MCAP with) and
# protobufjs (Node.js), for the test that parses every recorded channel by Foxglove's rules
# (tools/foxglove_check/check.mjs, tests/test_foxglove.py; pinned in package-lock.json). Without
# npm the test skips, saying why; with HIL_REQUIRE_FOXGLOVE=1 (.ci/run) the build stops here.
FOXGLOVE_STAMP := tools/foxglove_check/node_modules/.installed
$(FOXGLOVE_STAMP): tools/foxglove_check/package-lock.json
	@if command -v npm >/dev/null 2>&1; then \
	  cd tools/foxglove_check && npm ci --no-audit --no-fund --loglevel=error && touch node_modules/.installed; \
	elif [ "$$HIL_REQUIRE_FOXGLOVE" = "1" ]; then \
	  echo "npm not found and HIL_REQUIRE_FOXGLOVE=1: install Node.js and npm (apt-get install nodejs npm)"; exit 1; \
	else echo "npm not found: tests/test_foxglove.py will skip (install Node.js to run it)"; fi

# The firmware cross-compiled for a Cortex-M4F (STM32F405 as QEMU's netduinoplus2 models it:
# firmware_stub/port/cortex_m, docs/ports.md), the controller of `--link pil-qemu`. Without the
# cross compiler it is skipped, saying why (tests/test_pil_qemu.py then skips); with
# HIL_REQUIRE_CORTEX_M=1 (.ci/run) the build stops here instead.
CM_BUILD := $(BUILD)/cortex_m
CM_PORT  := firmware_stub/port/cortex_m
firmware-cm4:
	@if command -v arm-none-eabi-gcc >/dev/null 2>&1; then \
	  cmake -S $(CM_PORT) -B $(CM_BUILD) -DCMAKE_TOOLCHAIN_FILE=$(CURDIR)/$(CM_PORT)/arm-none-eabi.cmake >/dev/null && \
	  cmake --build $(CM_BUILD) -j2; \
	elif [ "$$HIL_REQUIRE_CORTEX_M" = "1" ]; then \
	  echo "arm-none-eabi-gcc not found and HIL_REQUIRE_CORTEX_M=1: apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm"; exit 1; \
	else echo "arm-none-eabi-gcc not found: the Cortex-M firmware is not built and tests/test_pil_qemu.py will skip (apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm)"; fi

build: $(STAMP) cmake firmware-cm4 $(FOXGLOVE_STAMP)

test-c: cmake
	ctest --test-dir $(BUILD) --output-on-failure

# The wheel, as `pip wheel .` makes it anywhere (scikit-build-core, isolated build environment,
# Release, only what it installs: CMake target hil_wheel); build/wheel keeps its CMake tree so a
# second `make wheel` compiles only what changed. tests/test_wheel.py inspects this file
# ($HIL_WHEEL) and .ci/run installs it into a fresh environment outside the checkout.
DIST    := dist
wheel: $(STAMP)
	rm -f $(DIST)/hil_bench-*.whl
	$(VPY) -m pip wheel --no-deps -q -w $(DIST) -C build-dir=$(BUILD)/wheel .
	@ls $(DIST)/hil_bench-*.whl

# pytest-xdist: one worker per CPU; the real-time tests on one of them, one after the other, and
# each module's shared fixture made once (tests/conftest.py, docs/performance.md "The test suite")
test-py: build wheel
	HIL_WHEEL=$$(ls $(DIST)/hil_bench-*.whl) $(VPY) -m pytest -q -n auto --dist loadgroup tests

test: build test-c sanitize wheel test-py

# AddressSanitizer + UndefinedBehaviorSanitizer build of every C target and C test, and of the
# cffi modules (the engine, the plant, the firmware library), which tools/build_native.py puts in
# an import root of their own, build-asan/python/, that tests/test_loop_sanitized.py loads
# (LD_PRELOAD of libasan) to run a closed loop with the sanitized engine and the sanitized stub.
sanitize: $(STAMP)
	cmake -S . -B $(BUILD)-asan -DCMAKE_BUILD_TYPE=Debug -DHIL_SANITIZE=ON $(CMAKE_PY) >/dev/null
	cmake --build $(BUILD)-asan -j2
	ctest --test-dir $(BUILD)-asan --output-on-failure
	$(VPY) tools/build_native.py --sanitize
	@test -f "$$(gcc -print-file-name=libasan.so)" || echo "sanitize: WARNING: gcc has no libasan.so: tests/test_loop_sanitized.py will skip"

demo: build
	$(VPY) -m hil_bench run $(SCENARIO)

perf: build
	$(VPY) -m hil_bench.perf.loop

# libFuzzer harnesses (clang; installs it with apt-get if missing, skips if it cannot):
# >= 10^6 executions per harness, or a 20 s pass per harness for CI (tests/fuzz/run.sh). The CI
# pass fails when it cannot fuzz (--require), so CI cannot go green without fuzzing.
fuzz:
	tests/fuzz/run.sh

fuzz-ci:
	tests/fuzz/run.sh --require --time 20

clean:
	rm -rf $(BUILD) $(BUILD)-asan $(DIST)
