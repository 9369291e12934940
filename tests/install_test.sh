#!/bin/sh
# Installs libaacbvh into a scratch prefix and uses it the two ways README.md
# documents: pkg-config (compiling examples/c-minimal.c with nothing but
# `pkg-config --cflags --libs aacbvh`) and a CMake project using
# find_package(aacbvh) + aacbvh::aacbvh (tests/find_package_project).
#
# usage: install_test.sh MODE SOURCE_DIR BUILD_DIR CMAKE C_COMPILER
#   MODE relocated: `cmake --install BUILD_DIR --prefix <scratch>`, i.e. a
#        prefix other than the configured one and the default, relative libdir.
#   MODE absolute:  a second library-only build configured with an absolute
#        CMAKE_INSTALL_LIBDIR (and a relative includedir), installed as configured.
# find_package accepts this version for the project's default request (1.0)
# and refuses another major version and a later minor one.
set -eu

mode=$1 src=$2 bin=$3 cmake=$4 cc=$5
work=$bin/install-test/$mode
prefix=$work/prefix
rm -rf "$prefix" "$work/consumer"
mkdir -p "$work"

step() { echo "--- $*"; }
fail() { echo "FAIL: $*"; exit 1; }

case $mode in
relocated)
    step "cmake --install $bin --prefix $prefix"
    "$cmake" --install "$bin" --prefix "$prefix"
    ;;
absolute)
    step "configure and build a library-only tree with CMAKE_INSTALL_LIBDIR=$prefix/abslib"
    # Only the install paths are under test: unoptimised (-O0) compiles in
    # half the time of Release on the 2-core CI machine.
    "$cmake" -S "$src" -B "$work/build" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O0 \
        -DBUILD_TESTING=OFF -DAACBVH_BUILD_EXAMPLES=OFF \
        -DCMAKE_C_COMPILER="$cc" \
        -DCMAKE_INSTALL_PREFIX="$prefix" -DCMAKE_INSTALL_LIBDIR="$prefix/abslib" \
        -DCMAKE_INSTALL_INCLUDEDIR=include > "$work/configure.log" ||
        { cat "$work/configure.log"; fail "configure"; }
    jobs=$(nproc 2>/dev/null || echo 2)
    "$cmake" --build "$work/build" --target aacbvh -j "$jobs"
    "$cmake" --install "$work/build"
    ;;
*)
    fail "unknown mode $mode"
    ;;
esac

pc=$(find "$prefix" -name aacbvh.pc | head -n 1)
[ -n "$pc" ] || fail "no aacbvh.pc installed under $prefix"
config=$(find "$prefix" -name aacbvhConfig.cmake | head -n 1)
[ -n "$config" ] || fail "no aacbvhConfig.cmake installed under $prefix"
echo "installed: $pc"
echo "installed: $config"

# ---- pkg-config ----
PKG_CONFIG_PATH=$(dirname "$pc")
export PKG_CONFIG_PATH
step "pkg-config: $(pkg-config --cflags --libs aacbvh)"
version=$(pkg-config --modversion aacbvh)
for var in includedir libdir; do
    dir=$(pkg-config --variable=$var aacbvh)
    case $(cd "$dir" && pwd -P) in
        "$(cd "$prefix" && pwd -P)"/*) ;;
        *) fail "pkg-config $var '$dir' is not inside $prefix" ;;
    esac
done
libdir=$(pkg-config --variable=libdir aacbvh)
[ -f "$(pkg-config --variable=includedir aacbvh)/aacbvh/aacbvh.h" ] || fail "header not under includedir"

# shellcheck disable=SC2046  # word splitting of the flags is intended
"$cc" -std=c99 -o "$work/c-minimal" "$src/examples/c-minimal.c" $(pkg-config --cflags --libs aacbvh)
out=$(LD_LIBRARY_PATH=$libdir "$work/c-minimal")
echo "$out"
echo "$out" | grep -q "^libaacbvh $version\$" || fail "c-minimal does not report version $version"
echo "$out" | grep -qxF "hit triangle 1 at t = 1 (u = 0.25, v = 0.5)" || fail "c-minimal did not print the expected hit"
# The program must have used the installed library, not the build tree's.
LD_LIBRARY_PATH=$libdir ldd "$work/c-minimal" | grep -q "$libdir/libaacbvh.so" ||
    fail "c-minimal did not load $libdir/libaacbvh.so"

# ---- find_package ----
# A libdir outside the standard search layout (the absolute case) is found
# through aacbvh_DIR, as a user would pass it.
find_args="-DCMAKE_PREFIX_PATH=$prefix"
[ "$mode" = absolute ] && find_args="-Daacbvh_DIR=$(dirname "$config")"
step "find_package(aacbvh) with $find_args"
"$cmake" -S "$src/tests/find_package_project" -B "$work/consumer" \
    "$find_args" -DCMAKE_C_COMPILER="$cc" > "$work/consumer.log" ||
    { cat "$work/consumer.log"; fail "configuring the find_package project"; }
"$cmake" --build "$work/consumer"
"$work/consumer/consumer"

# SameMajorVersion: asking for another major version must fail.
step "find_package(aacbvh 99.0) must fail"
if "$cmake" -S "$src/tests/find_package_project" -B "$work/consumer-wrong" \
    "$find_args" -DCMAKE_C_COMPILER="$cc" -DAACBVH_WANTED_VERSION=99.0 \
    > "$work/consumer-wrong.log" 2>&1; then
    fail "find_package(aacbvh 99.0) accepted version $version"
fi
rm -rf "$work/consumer-wrong"
# ... and so must asking for a later minor version: it may use what this one lacks.
major=${version%%.*}
minor=${version#*.}
minor=${minor%%.*}
later="$major.$((minor + 1))"
step "find_package(aacbvh $later) must fail"
if "$cmake" -S "$src/tests/find_package_project" -B "$work/consumer-later" \
    "$find_args" -DCMAKE_C_COMPILER="$cc" -DAACBVH_WANTED_VERSION="$later" \
    > "$work/consumer-later.log" 2>&1; then
    fail "find_package(aacbvh $later) accepted version $version"
fi
rm -rf "$work/consumer-later"
echo "ok: install ($mode) works with pkg-config and find_package, version $version"
