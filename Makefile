# One entry point for a fresh clone. `make demo` and `make test` need nothing done by hand:
# they create .venv, install the Python dependencies, build all C (CMake) and the cffi modules.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
BUILD   := build
SCENARIO ?= bench/scenarios/gong_g2_500rpm.toml

.PHONY: all build native cmake test test-c test-py sanitize demo perf clean fuzz fuzz-ci

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

build: $(STAMP) cmake native

test-c: cmake
	ctest --test-dir $(BUILD) --output-on-failure

test-py: build
	$(VPY) -m pytest -q tests

test: build test-c sanitize test-py

# AddressSanitizer + UndefinedBehaviorSanitizer build of every C target and C test.
sanitize:
	cmake -S . -B $(BUILD)-asan -DCMAKE_BUILD_TYPE=Debug -DHIL_SANITIZE=ON >/dev/null
	cmake --build $(BUILD)-asan -j2
	ctest --test-dir $(BUILD)-asan --output-on-failure

demo: build
	$(VPY) -m bench run $(SCENARIO)

perf: build
	$(VPY) -m bench.perf.loop

# libFuzzer harnesses (clang; installs it with apt-get if missing, skips if it cannot):
# >= 10^6 executions per harness, or a 20 s pass per harness for CI (tests/fuzz/run.sh).
fuzz:
	tests/fuzz/run.sh

fuzz-ci:
	tests/fuzz/run.sh --time 20

clean:
	rm -rf $(BUILD) $(BUILD)-asan
