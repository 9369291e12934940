#!/usr/bin/env bash
# Builds libaacbvh and runs every test three times over:
#   1. a Release build                      (<build>)
#   2. AddressSanitizer + UBSan             (<build>-asan, -DAACBVH_SANITIZE=address,undefined)
#   3. ThreadSanitizer                      (<build>-tsan, -DAACBVH_SANITIZE=thread)
# each with `ctest --output-on-failure`; then valgrind memcheck over the fast
# C API tests of stage 1 and a 60 s libFuzzer run (scripts/fuzz.sh,
# <build>-fuzz), whose tools are installed when missing (as root with
# apt-get), else those two stages are skipped. Every stage runs even if an earlier
# one failed; the exit status is non-zero if any did. Idempotent: reruns
# reuse the build directories.
# AACBVH_SANITIZERS=0 leaves out the sanitizer stages, AACBVH_VALGRIND=0 and
# AACBVH_FUZZ=0 the valgrind and fuzz stages.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

require_tools cmake c++ cc make pkg-config nm readelf

# Tools that some tests need, installed here when possible (CI runs this as
# root on Debian, after the README command's apt-get update); without them
# those tests report themselves skipped.
#   abigail-tools (abidiff): abi_baseline, the ABI against tests/abi/libaacbvh.abi
#   python3: python_binding and python_example, the ctypes binding in examples/python
#   python3-numpy: python_numpy; python3-venv, python3-setuptools, python3-wheel:
#   python_install, the binding's offline pip install (Debian packages, asked of dpkg)
optional=()
command -v abidiff > /dev/null 2>&1 || optional+=(abigail-tools)
command -v python3 > /dev/null 2>&1 || optional+=(python3)
if command -v dpkg > /dev/null 2>&1; then
    for package in python3-numpy python3-venv python3-setuptools python3-wheel; do
        dpkg -s "$package" > /dev/null 2>&1 || optional+=("$package")
    done
fi
if [ ${#optional[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get > /dev/null 2>&1; then
        log "installing ${optional[*]} for the ABI and Python binding tests"
        DEBIAN_FRONTEND=noninteractive apt-get install -y "${optional[@]}" ||
            echo "could not install ${optional[*]}: their tests will be skipped" >&2
    else
        echo "not installed: ${optional[*]} (apt-get install -y ${optional[*]}): their tests will be skipped" >&2
    fi
fi
failed=()
probe_dir=$(mktemp -d)
trap 'rm -rf "$probe_dir"' EXIT

# run_stage NAME BUILD_DIR RUNNER -- CMAKE_ARGS...: configure, build, ctest.
# RUNNER is a command prefix for ctest (e.g. setarch) or empty.
run_stage() {
    local name=$1 dir=$2 runner=$3
    shift 4
    log "$name: configure and build in $dir"
    if ! configure "$dir" "$@" || ! cmake --build "$dir" -j "$AACBVH_JOBS"; then
        failed+=("$name (build)")
        return 0
    fi
    log "$name: ctest"
    # shellcheck disable=SC2086  # runner is a word list on purpose
    if ! (cd "$dir" && $runner ctest --output-on-failure -j "$AACBVH_JOBS"); then
        failed+=("$name (tests)")
    fi
}

# Sanitizer runtimes reserve fixed address ranges. On some kernels (large
# vm.mmap_rnd_bits) that fails with "unexpected memory mapping"; running the
# tests with address randomisation off (setarch -R, for the test processes
# only) fixes it. This script never changes the machine's kernel settings
# (it does not lower vm.mmap_rnd_bits, even as root): where setarch -R is not
# enough, the stage fails and says so.
# Prints the runner prefix that makes a probe program work, or fails.
sanitizer_runner() {
    local flags=$1 probe=$probe_dir/probe-${1//[^a-z]/_}
    cat > "$probe_dir/probe.cpp" <<'CPP'
#include <cstdio>
#include <thread>
#include <vector>
int main() {
    std::vector<int> v(1000, 1);
    int sum = 0;
    std::thread t([&] { for (int x : v) sum += x; });
    t.join();
    std::printf("%d\n", sum);
    return sum == 1000 ? 0 : 1;
}
CPP
    c++ -std=c++17 -fsanitize="$flags" -g "$probe_dir/probe.cpp" -o "$probe" -pthread >&2 || return 1
    if "$probe" > /dev/null 2>&1; then
        echo ""
        return 0
    fi
    # LeakSanitizer cannot run under ptrace (some CI sandboxes): keep the
    # rest of ASan and say so.
    if "$probe" 2>&1 | grep -q LeakSanitizer; then
        local options=${ASAN_OPTIONS//detect_leaks=1/detect_leaks=0}
        if env ASAN_OPTIONS="$options" "$probe" > /dev/null 2>&1; then
            echo "LeakSanitizer does not work here: running with detect_leaks=0" >&2
            echo "env ASAN_OPTIONS=$options"
            return 0
        fi
    fi
    local setarch_cmd
    setarch_cmd="setarch $(uname -m) -R"
    if $setarch_cmd "$probe" > /dev/null 2>&1; then
        echo "sanitizer probe ($flags) needs address randomisation off: using '$setarch_cmd'" >&2
        echo "$setarch_cmd"
        return 0
    fi
    echo "sanitizer probe ($flags) does not run on this machine, not even under '$setarch_cmd'" >&2
    echo "(on kernels with a large vm.mmap_rnd_bits, the machine's owner can lower it:" >&2
    echo "sysctl vm.mmap_rnd_bits=28; this script leaves kernel settings alone):" >&2
    "$probe" >&2 || true
    return 1
}

# -DBUILD_TESTING=ON: without cmocka the configure step fails and says what to
# install, instead of leaving the tests out.
# The Python tests use Debian's python3 where it is there: it is the one the
# apt-installed numpy, venv, setuptools and wheel belong to (a pyenv or conda
# python3 first on PATH would skip python_numpy and python_install).
python_args=()
[ -x /usr/bin/python3 ] && python_args=(-DPython3_EXECUTABLE=/usr/bin/python3)
run_stage "release" "$AACBVH_BUILD_DIR" "" -- -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON "${python_args[@]}"

if [ "${AACBVH_SANITIZERS:-1}" != 0 ]; then
    # Sanitized builds keep line tables (-g1) for readable reports: file and
    # line in every stack, a third less compile time than full -g on the
    # 2-core CI machine. Any report fails the test.
    sanitizer_flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DBUILD_TESTING=ON
                     "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
                     "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG")
    export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:check_initialization_order=1:strict_init_order=1}
    export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
    export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1}

    if runner=$(sanitizer_runner address,undefined); then
        run_stage "asan+ubsan" "$AACBVH_BUILD_DIR-asan" "$runner" -- \
            "${sanitizer_flags[@]}" -DAACBVH_SANITIZE=address,undefined
    else
        failed+=("asan+ubsan (sanitizer does not run here)")
    fi
    if runner=$(sanitizer_runner thread); then
        run_stage "tsan" "$AACBVH_BUILD_DIR-tsan" "$runner" -- \
            "${sanitizer_flags[@]}" -DAACBVH_SANITIZE=thread
    else
        failed+=("tsan (sanitizer does not run here)")
    fi
fi

# install_if_missing COMMAND PACKAGE...: succeeds when COMMAND is there, or
# could be installed (as root, with apt-get). Installing here keeps README's
# command unchanged for the tools of the two stages below.
install_if_missing() {
    local cmd=$1
    shift
    command -v "$cmd" > /dev/null 2>&1 && return 0
    if [ "$(id -u)" = 0 ] && command -v apt-get > /dev/null 2>&1; then
        log "installing $* (for $cmd)"
        export DEBIAN_FRONTEND=noninteractive
        apt-get install -y "$@" > /dev/null 2>&1 ||
            { apt-get update > /dev/null && apt-get install -y "$@" > /dev/null; } || true
    fi
    command -v "$cmd" > /dev/null 2>&1
}

# Valgrind memcheck over the faster C API tests of the Release build (leaks
# and invalid reads the sanitizer builds cannot see in uninstrumented code
# paths); AACBVH_TEST_QUICK=1 shortens the watertight test. Valgrind runs one
# thread at a time: AACBVH_JOBS tests at once, the longest
# (test_ray_directions, two thirds of the total) first. About half a minute.
if [ "${AACBVH_VALGRIND:-1}" != 0 ]; then
    if install_if_missing valgrind valgrind; then
        log "valgrind: memcheck over the fast C API tests ($AACBVH_JOBS at a time)"
        valgrind_tests=(test_ray_directions test_watertight test_aac_exact test_refit test_bad_input
                        test_errors test_params test_version test_layout)
        for t in "${valgrind_tests[@]}"; do
            exe=$AACBVH_BUILD_DIR/tests/$t
            rm -f "$AACBVH_BUILD_DIR/valgrind-$t.status"
            [ -x "$exe" ] || continue
            while [ "$(jobs -rp | wc -l)" -ge "$AACBVH_JOBS" ]; do wait -n || true; done
            (
                status=0
                AACBVH_TEST_QUICK=1 valgrind -q --error-exitcode=1 --leak-check=full "$exe" \
                    > "$AACBVH_BUILD_DIR/valgrind-$t.log" 2>&1 || status=$?
                echo "$status" > "$AACBVH_BUILD_DIR/valgrind-$t.status"
            ) &
        done
        wait
        for t in "${valgrind_tests[@]}"; do
            if [ ! -x "$AACBVH_BUILD_DIR/tests/$t" ]; then
                failed+=("valgrind ($t not built)")
            elif [ "$(cat "$AACBVH_BUILD_DIR/valgrind-$t.status" 2> /dev/null)" = 0 ]; then
                echo "valgrind: $t clean"
            else
                cat "$AACBVH_BUILD_DIR/valgrind-$t.log"
                failed+=("valgrind ($t)")
            fi
        done
    else
        log "valgrind: SKIPPED: valgrind is not installed (apt-get install -y valgrind)"
    fi
fi

# The libFuzzer harness over the committed corpus, AACBVH_FUZZ_SECONDS (60) long.
if [ "${AACBVH_FUZZ:-1}" != 0 ]; then
    install_if_missing clang++-14 clang-14 libclang-rt-14-dev || true
    # Debian's image may have clang-14 without its libFuzzer runtime: the
    # command is there, the library is not.
    if [ "$(id -u)" = 0 ] && command -v dpkg > /dev/null 2>&1 && ! dpkg -s libclang-rt-14-dev > /dev/null 2>&1; then
        log "installing libclang-rt-14-dev (libFuzzer for clang++-14)"
        DEBIAN_FRONTEND=noninteractive apt-get install -y libclang-rt-14-dev > /dev/null 2>&1 ||
            { apt-get update > /dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y libclang-rt-14-dev > /dev/null; } ||
            true
    fi
    if ! bash "$AACBVH_ROOT/scripts/fuzz.sh"; then
        failed+=("fuzz")
    fi
fi

if [ ${#failed[@]} -gt 0 ]; then
    log "FAILED: ${failed[*]}"
    exit 1
fi
log "all test stages passed"
