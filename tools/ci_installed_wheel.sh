#!/usr/bin/env bash
# The installed wheel, outside the checkout (.ci/run calls it after `make test`):
#   tools/ci_installed_wheel.sh dist/hil_bench-<version>-<tags>.whl
# A fresh virtual environment in a temporary folder gets the wheel and its dependencies from
# PyPI, from that folder (no checkout on any path):
# 1. the core alone (`pip install <wheel>`, as a user does: README "As a package"): its size (must
#    stay under CORE_MAX_MB, and within 15 % of README's figure), `bench --version`,
#    `bench run gong_g2_500rpm` (claims must hold: --strict), `bench check` of that recording, the
#    API's one-liner, and the bundled sweep and campaign by name saying the extra they need
#    ([cluster]);
# 2. then `[all]` into the same environment, its size, and examples/firmware_ci's tests with the
#    pytest plugin against the bundled stub (their JUnit XML kept in the folder).
set -euo pipefail
wheel=$(realpath "$1")
repo=$(cd "$(dirname "$0")/.." && pwd)
PY=${PY:-python3}
CORE_MAX_MB=${CORE_MAX_MB:-250}
scratch=$(mktemp -d "${TMPDIR:-/tmp}/hil-wheel-XXXXXX")
echo "ci: installed wheel: $(basename "$wheel") into $scratch/venv"
t0=$(date +%s)
pip_install() {
    "$scratch/venv/bin/python" -m pip install -q --disable-pip-version-check "$@"
}
# the venv's own pip (ensurepip) installs wheels: no upgrade round trip
"$PY" -m venv "$scratch/venv"
pip_install "$wheel"
core_mb=$(du -sm "$scratch/venv" | cut -f1)
echo "ci: core installed in $(( $(date +%s) - t0 )) s: venv $core_mb MB (du -sm; limit $CORE_MAX_MB MB)"
[ "$core_mb" -lt "$CORE_MAX_MB" ] || { echo "ci: the core install is $core_mb MB, not under $CORE_MAX_MB MB"; exit 1; }
# README.md's figure of the core ("| (core) | ... | N MB |", measured the same way) is this one
# within README_MB_TOLERANCE_PCT: a figure that drifted further is stale, and says so here
README_MB_TOLERANCE_PCT=${README_MB_TOLERANCE_PCT:-15}
readme_mb=$(sed -n 's/^| (core) |.*| \([0-9][0-9]*\) MB |$/\1/p' "$repo/README.md")
[ -n "$readme_mb" ] || { echo "ci: README.md's extras table has no (core) venv size"; exit 1; }
off=$(( core_mb > readme_mb ? core_mb - readme_mb : readme_mb - core_mb ))
[ $(( off * 100 )) -le $(( readme_mb * README_MB_TOLERANCE_PCT )) ] \
    || { echo "ci: README.md says the core venv is $readme_mb MB, it is $core_mb MB (more than $README_MB_TOLERANCE_PCT % off): re-measure it"; exit 1; }
cp -r "$repo/examples/firmware_ci" "$scratch/firmware_ci"
cd "$scratch"
case "$(venv/bin/python -c 'import hil_bench, os; print(os.path.dirname(hil_bench.__file__))')" in
    "$scratch"/venv/*) ;;
    *) echo "ci: hil_bench is not imported from the fresh environment"; exit 1 ;;
esac
venv/bin/bench --version
venv/bin/bench run gong_g2_500rpm --out g2.mcap --no-progress --strict
venv/bin/bench check g2.mcap --strict >/dev/null
venv/bin/python -c "import hil_bench; print(hil_bench.run('gong_g2_500rpm', out='api.mcap').claims)"
# the bundled sweep and campaign resolve by name from the wheel, then say the extra they need
for cmd in "sweep observers_speed_load" "campaign g2_protection"; do
    rc=0
    err=$(venv/bin/bench $cmd --out extra_out 2>&1 >/dev/null) || rc=$?
    [ "$rc" = 2 ] && grep -q "pip install 'hil-bench\[cluster" <<<"$err" && [ ! -e extra_out ] \
        || { echo "ci: bench $cmd without Dask (exit $rc) did not name the extra: $err"; exit 1; }
    echo "ci: $err"
done
echo "ci: core checked in $(( $(date +%s) - t0 )) s"
# everything else, compiled lazily (no byte-compiling of the extras' thousands of modules up front)
pip_install --no-compile "$wheel[all]" "pytest>=7"
echo "ci: [all] and pytest installed in $(( $(date +%s) - t0 )) s: venv $(du -sm venv | cut -f1) MB (without .pyc)"
help=$(venv/bin/pytest --help)
grep -q -- "--hil-link=SPEC" <<<"$help" || { echo "ci: pytest --help has no --hil-link"; exit 1; }
# under the newest pytest from PyPI, a deprecation is an error (the plugin must not lean on one)
(cd firmware_ci && ../venv/bin/pytest -W error::DeprecationWarning -p no:cacheprovider -q \
     --junitxml="$scratch/firmware_ci.xml")
echo "ci: installed wheel checked in $(( $(date +%s) - t0 )) s ($scratch)"
