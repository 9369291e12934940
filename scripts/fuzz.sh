#!/usr/bin/env bash
# Builds the libFuzzer harness (tests/fuzz/fuzz_api.cpp, the library compiled
# in with -fsanitize=fuzzer,address,undefined) and runs it for a fixed time
# over the committed corpus tests/fuzz/corpus/. New inputs it finds go to a
# scratch directory (merge good ones into the corpus by hand with -merge=1);
# a crash leaves its input in the build directory and fails the script.
# The fuzzer's own output (thousands of lines) goes to <build>-fuzz/fuzz.log;
# the script prints one summary line (runs, coverage, time, result), and the
# log's last lines only when the run fails.
# Environment knobs (besides those of common.sh):
#   AACBVH_FUZZ_SECONDS    run time (default 60)
#   AACBVH_FUZZ_BUILD_DIR  build directory (default <build>-fuzz)
#   AACBVH_FUZZ_CXX        clang++ with libFuzzer (default clang++-14)
# Without clang or libFuzzer (Debian: clang-14 libclang-rt-14-dev) it says so
# and exits 0: the stage is skipped, not failed.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

seconds=${AACBVH_FUZZ_SECONDS:-60}
dir=${AACBVH_FUZZ_BUILD_DIR:-$AACBVH_BUILD_DIR-fuzz}
cxx=${AACBVH_FUZZ_CXX:-clang++-14}
corpus=$AACBVH_ROOT/tests/fuzz/corpus

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
skip() {
    log "fuzz: SKIPPED: $*"
    echo "install them with: apt-get install -y clang-14 libclang-rt-14-dev" >&2
    exit 0
}
command -v "$cxx" > /dev/null 2>&1 || skip "$cxx not found"
echo 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char *, unsigned long) { return 0; }' \
    > "$scratch/probe.cpp"
"$cxx" -fsanitize=fuzzer "$scratch/probe.cpp" -o "$scratch/probe" > /dev/null 2>&1 ||
    skip "$cxx cannot link -fsanitize=fuzzer (libFuzzer missing)"

log "fuzz: configure and build in $dir"
cmake -S "$AACBVH_ROOT/tests/fuzz" -B "$dir" -DAACBVH_BUILD_FUZZER=ON -DCMAKE_CXX_COMPILER="$cxx"
cmake --build "$dir" -j "$AACBVH_JOBS"

inputs=$(find "$corpus" -type f | wc -l)
log "fuzz: $seconds s over $inputs corpus inputs"
mkdir -p "$scratch/new"
fuzz_log=$dir/fuzz.log
touch "$scratch/started"
start=$(date +%s)
set +e
# shellcheck disable=SC2086  # extra libFuzzer flags are a word list
"$dir/aacbvh-fuzz-api" -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$dir/" ${AACBVH_FUZZ_FLAGS:-} "$scratch/new" "$corpus" \
    > "$fuzz_log" 2>&1
rc=$?
set -e
elapsed=$(($(date +%s) - start))

# From libFuzzer's output: executions (its final stats, else the last status
# line "#N ..."), and coverage from the last status line ("cov: edges ft:
# features corp: inputs/size").
runs=$(sed -n 's/^stat::number_\(of_\)\{0,1\}executed_units: *\([0-9][0-9]*\).*/\2/p' "$fuzz_log" | tail -n 1)
status_line=$(grep -E '^#[0-9]+[[:space:]].* cov: ' "$fuzz_log" | tail -n 1 || true)
[ -n "$runs" ] || runs=$(printf '%s\n' "$status_line" | sed -n 's/^#\([0-9][0-9]*\).*/\1/p')
field() { printf '%s\n' "$status_line" | sed -n "s/.* $1: \\([^ ]*\\).*/\\1/p"; }
cov=$(field cov) ft=$(field ft) corp=$(field corp)
new_inputs=$(find "$scratch/new" -type f | wc -l)
summary="${runs:-?} runs in $elapsed s, coverage ${cov:-?} edges / ${ft:-?} features, corpus ${corp:-?} ($new_inputs new inputs)"
if [ "$rc" -eq 0 ]; then
    echo "fuzz: ok: $summary; log: $fuzz_log"
else
    echo "fuzz: FAILED (exit $rc): $summary; log: $fuzz_log"
    echo "--- last 60 lines of $fuzz_log:"
    tail -n 60 "$fuzz_log"
    find "$dir" -maxdepth 1 -type f -newer "$scratch/started" \
        \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) |
        sed 's/^/input that failed: /'
    exit 1
fi
