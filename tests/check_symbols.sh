#!/bin/sh
# Checks the shared library's ABI surface:
#  1. the dynamic symbols it defines are exactly the committed list,
#  2. the committed list is exactly the functions the public header declares
#     (so adding an AACBVH_API function without updating the list fails),
#  3. every exported symbol carries the version node the list gives it (the
#     linker script's node of the minor version that added it),
#  4. its SONAME is the expected one.
# usage: check_symbols.sh LIBRARY EXPECTED_LIST HEADER EXPECTED_SONAME
# EXPECTED_LIST: one "function VERSION_NODE" per line.
set -eu

lib=$1 expected=$2 header=$3 soname=$4
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
status=0

# Global defined symbols: every upper-case type, plus unique (u) and
# ifunc (i) ones; "A" entries are the version nodes themselves.
nm -D --defined-only "$lib" |
    awk 'NF >= 3 && $2 ~ /^[BCDGRSTVWui]$/ { print $3 }' > "$tmp/versioned"
sed 's/@.*//' "$tmp/versioned" | LC_ALL=C sort -u > "$tmp/exported"
awk '{ print $1 }' "$expected" | LC_ALL=C sort -u > "$tmp/expected"

if ! diff -u "$tmp/expected" "$tmp/exported" > "$tmp/diff"; then
    echo "FAIL: exported symbols differ from $expected (- expected, + exported):"
    cat "$tmp/diff"
    status=1
else
    echo "ok: $(wc -l < "$tmp/exported") exported symbols match $expected"
fi

grep -E '^AACBVH_API ' "$header" |
    sed -E 's/^([^(]*[^A-Za-z0-9_])?([A-Za-z_][A-Za-z0-9_]*)\(.*/\2/' |
    LC_ALL=C sort -u > "$tmp/declared"
if ! diff -u "$tmp/expected" "$tmp/declared" > "$tmp/diff"; then
    echo "FAIL: $expected differs from the AACBVH_API functions of $header (- list, + header):"
    cat "$tmp/diff"
    status=1
else
    echo "ok: $expected matches the functions declared in $(basename "$header")"
fi

# nm prints symbol versions as name@@NODE (the default version) when the
# library has them.
if grep -q '@' "$tmp/versioned"; then
    sed 's/@@*/ /' "$tmp/versioned" | LC_ALL=C sort -u > "$tmp/nodes"
    LC_ALL=C sort -u "$expected" > "$tmp/expected_nodes"
    if [ "$(grep -c '@@' "$tmp/versioned")" -ne "$(wc -l < "$tmp/versioned")" ] ||
       ! diff -u "$tmp/expected_nodes" "$tmp/nodes" > "$tmp/diff"; then
        echo "FAIL: exported symbols' version nodes differ from $expected (- expected, + exported):"
        cat "$tmp/diff"
        cat "$tmp/versioned"
        status=1
    else
        echo "ok: every exported symbol carries its version node ($(awk '{ print $2 }' "$tmp/nodes" | sort -u | tr '\n' ' '))"
    fi
else
    echo "FAIL: exported symbols carry no version (is the linker version script in use?)"
    status=1
fi

actual=$(readelf -d "$lib" | sed -n 's/.*Library soname: \[\(.*\)\].*/\1/p')
if [ "$actual" != "$soname" ]; then
    echo "FAIL: SONAME is '$actual', expected '$soname'"
    status=1
else
    echo "ok: SONAME is $actual"
fi
exit $status
