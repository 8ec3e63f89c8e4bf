#!/usr/bin/env bash
# The installed wheel, outside the checkout (.ci/run calls it after `make test`):
#   tools/ci_installed_wheel.sh dist/hil_bench-<version>-<tags>.whl
# A fresh virtual environment in a temporary folder gets the wheel and its dependencies from
# PyPI; from that folder (no checkout on any path) `bench --version`, `bench run gong_g2_500rpm`
# (claims must hold: --strict), the API's one-liner, and examples/firmware_ci's tests with the
# pytest plugin against the bundled stub (their JUnit XML kept in the folder).
set -euo pipefail
wheel=$(realpath "$1")
repo=$(cd "$(dirname "$0")/.." && pwd)
PY=${PY:-python3}
scratch=$(mktemp -d "${TMPDIR:-/tmp}/hil-wheel-XXXXXX")
echo "ci: installed wheel: $(basename "$wheel") into $scratch/venv"
t0=$(date +%s)
# the venv's own pip (ensurepip) installs wheels: no upgrade round trip; no byte-compiling of the
# dependencies' thousands of modules up front (what runs compiles its own on first import)
"$PY" -m venv "$scratch/venv"
"$scratch/venv/bin/python" -m pip install -q --disable-pip-version-check --no-compile "$wheel" "pytest>=7"
echo "ci: installed in $(( $(date +%s) - t0 )) s"
cp -r "$repo/examples/firmware_ci" "$scratch/firmware_ci"
cd "$scratch"
case "$(venv/bin/python -c 'import hil_bench, os; print(os.path.dirname(hil_bench.__file__))')" in
    "$scratch"/venv/*) ;;
    *) echo "ci: hil_bench is not imported from the fresh environment"; exit 1 ;;
esac
venv/bin/bench --version
venv/bin/bench run gong_g2_500rpm --out g2.mcap --no-progress --strict
venv/bin/python -c "import hil_bench; print(hil_bench.run('gong_g2_500rpm', out='api.mcap').claims)"
help=$(venv/bin/pytest --help)
grep -q -- "--hil-link=SPEC" <<<"$help" || { echo "ci: pytest --help has no --hil-link"; exit 1; }
(cd firmware_ci && ../venv/bin/pytest -p no:cacheprovider -q --junitxml="$scratch/firmware_ci.xml")
echo "ci: installed wheel checked in $(( $(date +%s) - t0 )) s ($scratch)"
