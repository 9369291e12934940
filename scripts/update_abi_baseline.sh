#!/usr/bin/env bash
# Writes tests/abi/libaacbvh-MAJOR.MINOR.abi, the ABI baseline of the release
# being made (the version of include/aacbvh/aacbvh.h), which the abi_baseline
# test then compares the library with, beside the baselines of the earlier
# releases of the major version. docs/ABI.md says when: at a release, and with
# a new major version.
#
# It never rewrites a baseline: a released ABI stays what it was. And it
# first checks the library against every existing baseline of the major
# version, so a new baseline cannot record an ABI that broke an older one.
# Needs abidw and abidiff (Debian: abigail-tools). Builds in $AACBVH_BUILD_DIR
# (default build/); commit the new file with the release.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

require_tools cmake c++ make abidw abidiff
header=$AACBVH_ROOT/include/aacbvh/aacbvh.h
major=$(sed -n 's/^#define AACBVH_VERSION_MAJOR \([0-9][0-9]*\)$/\1/p' "$header")
minor=$(sed -n 's/^#define AACBVH_VERSION_MINOR \([0-9][0-9]*\)$/\1/p' "$header")
if [ -z "$major" ] || [ -z "$minor" ]; then
    echo "no version macros in $header" >&2
    exit 1
fi
abi_dir=$AACBVH_ROOT/tests/abi
target=$abi_dir/libaacbvh-$major.$minor.abi
if [ -e "$target" ]; then
    echo "$target exists: the baseline of release $major.$minor is never rewritten (docs/ABI.md)." >&2
    echo "A release with a new ABI raises the minor version (additions) or the major version." >&2
    exit 1
fi

log "configure and build the ABI probe in $AACBVH_BUILD_DIR"
configure "$AACBVH_BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON
cmake --build "$AACBVH_BUILD_DIR" -j "$AACBVH_JOBS" --target aacbvh_abi_probe
probe=$(find "$AACBVH_BUILD_DIR/tests/abi" -maxdepth 1 -name 'libaacbvh.so.*.*' | head -n 1)
[ -n "$probe" ] || { echo "no probe library under $AACBVH_BUILD_DIR/tests/abi" >&2; exit 1; }

shopt -s nullglob
earlier=("$abi_dir"/libaacbvh-"$major".*.abi)
if [ ${#earlier[@]} -gt 0 ]; then
    log "the ABI against the earlier baselines of major version $major"
    sh "$abi_dir/check_abi.sh" check "$probe" "$AACBVH_ROOT/include/aacbvh" \
        "$abi_dir/suppressions.abignore" "${earlier[@]}"
elif [ "$minor" != 0 ]; then
    echo "no baseline of version $major.0 under $abi_dir: the first release's ABI must be kept" >&2
    exit 1
fi
log "write $target"
sh "$abi_dir/check_abi.sh" dump "$probe" "$AACBVH_ROOT/include/aacbvh" "$target"
