# Shared by scripts/demo.sh and scripts/test.sh (sourced, not run).
# Environment knobs:
#   AACBVH_BUILD_DIR  build directory (default <repo>/build; the sanitizer
#                     builds go to the same path with -asan / -tsan appended)
#   AACBVH_JOBS       parallel compile and test jobs (default: nproc)

AACBVH_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
AACBVH_BUILD_DIR=${AACBVH_BUILD_DIR:-$AACBVH_ROOT/build}
AACBVH_JOBS=${AACBVH_JOBS:-$(nproc 2>/dev/null || echo 2)}
AACBVH_PACKAGES="cmake g++ make pkg-config libcmocka-dev libtinyobjloader-dev"

log() { printf '\n=== [%s] %s\n' "$(date +%T)" "$*"; }

# Fails early, with the command that fixes it, when a tool is missing.
require_tools() {
    local missing=()
    local tool
    for tool in "$@"; do
        command -v "$tool" > /dev/null 2>&1 || missing+=("$tool")
    done
    if [ ${#missing[@]} -gt 0 ]; then
        echo "missing: ${missing[*]}" >&2
        echo "install them with: apt-get update && apt-get install -y $AACBVH_PACKAGES" >&2
        exit 1
    fi
}

# configure BUILD_DIR [cmake args...]: idempotent; reuses an existing tree.
configure() {
    local dir=$1
    shift
    cmake -S "$AACBVH_ROOT" -B "$dir" "$@"
}
