#!/bin/sh
# Compares the C ABI of libaacbvh with the committed baselines, using
# libabigail (Debian package abigail-tools), or writes a baseline.
#
# usage: check_abi.sh dump  LIBRARY HEADERS_DIR OUT.abi
#        check_abi.sh check LIBRARY HEADERS_DIR SUPPRESSIONS BASELINE.abi...
#
# There is one baseline per release of the major version
# (tests/abi/libaacbvh-1.0.abi, -1.1.abi, ...), never rewritten: check compares
# the library with every one given, so what 1.0 promised stays guarded
# whatever later baselines say.
#
# LIBRARY must carry DWARF debug information for the C entry points (the
# build's aacbvh_abi_probe target: capi.cpp compiled with -g and linked like
# libaacbvh). Types defined outside HEADERS_DIR (the C++ internals behind the
# opaque handles) are private and left out.
#
# check fails when abidiff reports an incompatible change (exit bit 8: a
# function removed, ...) or any other ABI change (bit 4: a changed signature,
# struct layout or enumerator value) except those docs/ABI.md allows and
# SUPPRESSIONS (plus --no-added-syms) filters out: added functions, added
# enumerators, fields added at the end of aacbvh_stats.
set -eu

ABIDW=${ABIDW:-abidw}
ABIDIFF=${ABIDIFF:-abidiff}

dump() { # LIBRARY HEADERS_DIR OUT
    "$ABIDW" --headers-dir "$2" --drop-private-types --exported-interfaces-only --no-corpus-path --short-locs \
        --type-id-style hash "$1" |
        sed "s|comp-dir-path='[^']*'|comp-dir-path='.'|" > "$3.tmp"
    mv "$3.tmp" "$3"
}

mode=${1:-}
case $mode in
dump)
    [ $# -eq 4 ] || { echo "usage: $0 dump LIBRARY HEADERS_DIR OUT.abi" >&2; exit 2; }
    dump "$2" "$3" "$4"
    echo "wrote $4 ($(grep -c '<elf-symbol ' "$4") ELF symbols) from $2"
    ;;
check)
    [ $# -ge 5 ] || { echo "usage: $0 check LIBRARY HEADERS_DIR SUPPRESSIONS BASELINE.abi..." >&2; exit 2; }
    lib=$2 headers=$3 suppressions=$4
    shift 4
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    dump "$lib" "$headers" "$tmp/current.abi"
    status=0
    for baseline in "$@"; do
        echo "--- against $baseline"
        set +e
        "$ABIDIFF" --no-added-syms --suppressions "$suppressions" "$baseline" "$tmp/current.abi" > "$tmp/report"
        rc=$?
        set -e
        cat "$tmp/report"
        # abidiff's exit status is a bit set: 1 error, 2 usage error, 4 ABI change,
        # 8 incompatible ABI change.
        if [ $((rc & 3)) -ne 0 ]; then
            echo "FAIL: abidiff could not compare with $baseline (exit $rc)"
            status=1
        elif [ $((rc & 8)) -ne 0 ]; then
            echo "FAIL: incompatible ABI change against $baseline (abidiff exit $rc)."
            echo "Within a major version this is not allowed (docs/ABI.md)."
            status=1
        elif [ $((rc & 4)) -ne 0 ]; then
            echo "FAIL: ABI change against $baseline (abidiff exit $rc) that docs/ABI.md does not allow."
            echo "Undo it, or start a new major version (docs/ABI.md); a released baseline is"
            echo "never rewritten to make this pass."
            status=1
        else
            echo "ok: the ABI of $lib is compatible with $baseline"
        fi
    done
    exit $status
    ;;
*)
    echo "usage: $0 dump|check ..." >&2
    exit 2
    ;;
esac
