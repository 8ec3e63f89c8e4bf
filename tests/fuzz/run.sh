#!/usr/bin/env bash
# libFuzzer harnesses of the C deframer, every message decoder and the firmware's receive path
# (tests/fuzz/*.c), built with clang -fsanitize=fuzzer,address,undefined.
#
#   tests/fuzz/run.sh                 # full pass: >= 1,000,000 executions per harness
#   tests/fuzz/run.sh --time 20       # CI: 20 s per harness
#   tests/fuzz/run.sh --runs N        # N executions per harness
#   tests/fuzz/run.sh --only session  # one harness (deframer | msgs | session)
#   tests/fuzz/run.sh --require ...   # CI: no libFuzzer is a failure (exit 1), not a skip
#
# Prints, per harness, the executions done and the result; exit 1 on a finding (the crashing
# input is left in build-fuzz/<harness>/ as crash-*), 0 otherwise. Without clang it tries
# `apt-get update && apt-get install -y clang` (root) and skips with a reason (exit 0) if that
# is impossible -- or, with --require, fails with that reason (exit 1). The corpora in tests/fuzz/corpus/<harness>/ are read, never written: new
# inputs go to build-fuzz/<harness>/corpus/.
set -u
HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
OUT="${FUZZ_OUT:-$ROOT/build-fuzz}"
RUNS=1000000
TIME=0
ONLY=""
REQUIRE=0
while [ $# -gt 0 ]; do
    case "$1" in
        --runs) RUNS="$2"; shift 2 ;;
        --time) TIME="$2"; shift 2 ;;
        --only) ONLY="$2"; shift 2 ;;
        --require) REQUIRE=1; shift ;;
        -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
        *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
    esac
done

find_clang() {
    for c in clang clang-19 clang-18 clang-17 clang-16 clang-15 clang-14; do
        if command -v "$c" >/dev/null 2>&1; then echo "$c"; return 0; fi
    done
    return 1
}

can_fuzz() { # compiler -> 0 if -fsanitize=fuzzer links
    local t; t="$(mktemp -d)"
    printf '#include <stdint.h>\n#include <stddef.h>\nint LLVMFuzzerTestOneInput(const uint8_t *d, size_t n);\nint LLVMFuzzerTestOneInput(const uint8_t *d, size_t n){(void)d;(void)n;return 0;}\n' > "$t/t.c"
    "$1" -fsanitize=fuzzer,address,undefined "$t/t.c" -o "$t/t" >/dev/null 2>&1
    local rc=$?
    rm -rf "$t"
    return $rc
}

CC="$(find_clang || true)"
if [ -z "$CC" ] || ! can_fuzz "$CC"; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
        echo "fuzz: clang with libFuzzer not found: apt-get install clang"
        (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq clang >/dev/null) \
            || echo "fuzz: apt-get install clang failed"
        CC="$(find_clang || true)"
        if [ -n "$CC" ] && ! can_fuzz "$CC"; then
            ver="$("$CC" --version | sed -n 's/.*clang version \([0-9]*\).*/\1/p')"
            DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "libclang-rt-$ver-dev" >/dev/null 2>&1 || true
        fi
    fi
fi
if [ -z "$CC" ] || ! can_fuzz "$CC"; then
    if [ "$REQUIRE" = 1 ]; then
        echo "fuzz: FAILED (--require): no clang with -fsanitize=fuzzer (not installed and could not be installed)" >&2
        exit 1
    fi
    echo "fuzz: SKIPPED: no clang with -fsanitize=fuzzer (not installed and could not be installed)"
    exit 0
fi

SRC_PROTO="$ROOT/protocol/c"
SRC_FW="$ROOT/firmware_stub/src"
CFLAGS=(-std=c99 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
        -fno-omit-frame-pointer -I"$SRC_PROTO" -I"$SRC_FW")
declare -A SOURCES=(
    [deframer]="$HERE/fuzz_deframer.c $SRC_PROTO/hil_framing.c $SRC_PROTO/hil_msgs.c"
    [msgs]="$HERE/fuzz_msgs.c $SRC_PROTO/hil_msgs.c $SRC_PROTO/hil_msgs_reflect.c"
    [session]="$HERE/fuzz_session.c $SRC_PROTO/hil_framing.c $SRC_PROTO/hil_msgs.c $(ls "$SRC_FW"/*.c | tr '\n' ' ')"
)
status=0
echo "fuzz: $("$CC" --version | head -1); $( [ "$TIME" != 0 ] && echo "$TIME s" || echo "$RUNS runs") per harness"
for h in deframer msgs session; do
    [ -n "$ONLY" ] && [ "$ONLY" != "$h" ] && continue
    dir="$OUT/$h"
    mkdir -p "$dir/corpus"
    # shellcheck disable=SC2086
    if ! "$CC" "${CFLAGS[@]}" ${SOURCES[$h]} -o "$dir/fuzz_$h" -lm 2> "$dir/build.log"; then
        echo "fuzz $h: BUILD FAILED"; cat "$dir/build.log"; status=1; continue
    fi
    if [ "$TIME" != 0 ]; then limit=(-max_total_time="$TIME"); else limit=(-runs="$RUNS"); fi
    (cd "$dir" && ./"fuzz_$h" "${limit[@]}" -max_len=4096 -print_final_stats=1 \
        -artifact_prefix="$dir/" "$dir/corpus" "$HERE/corpus/$h" > "$dir/log.txt" 2>&1)
    rc=$?
    execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log.txt" | tail -1)"
    secs="$(sed -n 's/^stat::.*elapsed.*//p' "$dir/log.txt")"
    cov="$(grep -o 'cov: [0-9]*' "$dir/log.txt" | tail -1)"
    if [ $rc -eq 0 ]; then
        echo "fuzz $h: ${execs:-?} executions, ${cov:-cov: ?}, no finding"
    else
        echo "fuzz $h: FINDING after ${execs:-?} executions (exit $rc): see $dir/log.txt"
        grep -E "ERROR|SUMMARY|runtime error|deadly signal" "$dir/log.txt" | head -5
        status=1
    fi
done
exit $status
