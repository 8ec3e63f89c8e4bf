# One entry point for a fresh clone. `make demo` and `make test` need nothing done by hand:
# they create .venv, install the Python dependencies, build all C (CMake) and the cffi modules.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
BUILD   := build
SCENARIO ?= bench/scenarios/gong_g2_500rpm.toml

.PHONY: all build native cmake firmware-cm4 test test-c test-py sanitize demo perf clean fuzz fuzz-ci

all: build

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip
	$(VPY) -m pip install -q -e '.[test]'
	touch $@

cmake:
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
	cmake --build $(BUILD) -j2

native: $(STAMP)
	$(VPY) tools/build_native.py

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

build: $(STAMP) cmake native firmware-cm4 $(FOXGLOVE_STAMP)

test-c: cmake
	ctest --test-dir $(BUILD) --output-on-failure

test-py: build
	$(VPY) -m pytest -q tests

test: build test-c sanitize test-py

# AddressSanitizer + UndefinedBehaviorSanitizer build of every C target and C test, and of the
# cffi modules (the engine, the plant, the firmware library) into build-asan/python/, which
# tests/test_loop_sanitized.py loads (LD_PRELOAD of libasan) to run a closed loop with the
# sanitized engine and the sanitized stub.
sanitize: $(STAMP)
	cmake -S . -B $(BUILD)-asan -DCMAKE_BUILD_TYPE=Debug -DHIL_SANITIZE=ON >/dev/null
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
	rm -rf $(BUILD) $(BUILD)-asan
