#!/usr/bin/env bash
# Rewrites tests/abi/libaacbvh.abi, the ABI baseline that the abi_baseline test
# compares the library with (docs/ABI.md says when to do this: at a release,
# or for a deliberate change before the first release of a major version).
# Needs abidw (Debian: abigail-tools). Builds in $AACBVH_BUILD_DIR (default
# build/); commit the rewritten file with the change that made it necessary.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

require_tools cmake c++ make abidw abidiff
log "configure and build the ABI probe in $AACBVH_BUILD_DIR"
configure "$AACBVH_BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON
cmake --build "$AACBVH_BUILD_DIR" -j "$AACBVH_JOBS" --target aacbvh_abi_probe
probe=$(find "$AACBVH_BUILD_DIR/tests/abi" -maxdepth 1 -name 'libaacbvh.so.*.*' | head -n 1)
[ -n "$probe" ] || { echo "no probe library under $AACBVH_BUILD_DIR/tests/abi" >&2; exit 1; }
sh "$AACBVH_ROOT/tests/abi/check_abi.sh" dump "$probe" "$AACBVH_ROOT/include/aacbvh" \
    "$AACBVH_ROOT/tests/abi/libaacbvh.abi"
