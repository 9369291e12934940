#!/bin/sh
# The library configures, builds and installs with only a compiler and CMake:
# README.md's `cmake -S . -B b && cmake --build b && cmake --install b` on a
# machine without cmocka or tinyobjloader. Those are hidden here by making
# every find_path and find_library look only under an empty directory
# (CMAKE_FIND_ROOT_PATH with the INCLUDE and LIBRARY modes ONLY), which hides
# them wherever they are installed; that the hiding works is itself checked
# (the configure with the tests asked for must fail for want of cmocka).
#
#  1. no test option: configures (tests left out, with a message; the built-in
#     OBJ reader chosen; the default build type, Release, with -O3 left out of
#     its flags), builds everything (library and examples), installs;
#     nothing in the build refers to cmocka or tinyobjloader, and the demo
#     reads an OBJ file with the built-in reader;
#  2. -DBUILD_TESTING=ON, and the 1.0 alias -DAACBVH_BUILD_TESTS=ON: configure
#     fails with a message that says what to install;
#  3. as a subproject (add_subdirectory) of a project whose BUILD_TESTING is ON:
#     configures, without libaacbvh's tests and examples.
#
# usage: minimal_build_test.sh SOURCE_DIR BUILD_DIR CMAKE C_COMPILER CXX_COMPILER
set -eu

src=$1 bin=$2 cmake=$3 cc=$4 cxx=$5
work=$bin/minimal-build-test
rm -rf "$work"
mkdir -p "$work/empty-root"

step() { echo "--- $*"; }
fail() { echo "FAIL: $*"; exit 1; }

# Word lists on purpose (no spaces in these paths: checked below).
case "$work$cc$cxx" in *" "*) fail "paths with spaces are not supported here: $work $cc $cxx" ;; esac
hide="-DCMAKE_FIND_ROOT_PATH=$work/empty-root -DCMAKE_FIND_ROOT_PATH_MODE_INCLUDE=ONLY -DCMAKE_FIND_ROOT_PATH_MODE_LIBRARY=ONLY"
compilers="-DCMAKE_C_COMPILER=$cc -DCMAKE_CXX_COMPILER=$cxx"
# Only what the build needs is under test, not its optimisation (the Release
# stage builds and tests the optimised code): the build type stays the
# project's default (Release), its flags lose -O3, which halves the compile
# time of the full build on the 2-core CI machine (about 100 -> 50 s).
unoptimised="-DCMAKE_C_FLAGS_RELEASE=-DNDEBUG -DCMAKE_CXX_FLAGS_RELEASE=-DNDEBUG"

# ---- 1. configure, build, install without test dependencies ----
build=$work/build prefix=$work/prefix
step "configure with cmocka and tinyobjloader hidden, no test option"
# shellcheck disable=SC2086
"$cmake" -S "$src" -B "$build" $compilers $hide $unoptimised -DCMAKE_INSTALL_PREFIX="$prefix" \
    > "$work/configure.log" 2>&1 || { cat "$work/configure.log"; fail "configure"; }
grep -q "cmocka not found, so the tests are left out" "$work/configure.log" ||
    { cat "$work/configure.log"; fail "configure did not say that the tests are left out"; }
grep -q "tinyobjloader not found, using the built-in OBJ reader" "$work/configure.log" ||
    { cat "$work/configure.log"; fail "configure did not choose the built-in OBJ reader"; }
grep -qx "BUILD_TESTING:BOOL=OFF" "$build/CMakeCache.txt" || fail "BUILD_TESTING is not OFF in the cache"
grep -qx "CMAKE_BUILD_TYPE:STRING=Release" "$build/CMakeCache.txt" || fail "the default build type is not Release"
[ ! -e "$build/tests" ] || fail "the tests directory was configured"

step "cmake --build $build"
jobs=$(nproc 2>/dev/null || echo 2)
"$cmake" --build "$build" -j "$jobs" > "$work/build.log" 2>&1 ||
    { tail -n 50 "$work/build.log"; fail "build"; }
if grep -rIil -e cmocka -e tinyobjloader "$build" --include=link.txt --include=flags.make \
    > "$work/refs.txt"; then
    cat "$work/refs.txt"
    fail "build rules refer to cmocka or tinyobjloader"
fi
for exe in c-minimal aacbvh-demo animated; do
    [ -x "$build/examples/$exe" ] || fail "examples/$exe was not built"
done
out=$("$build/examples/c-minimal")
echo "$out" | grep -qxF "hit triangle 1 at t = 1 (u = 0.25, v = 0.5)" || fail "c-minimal printed: $out"
# A unit square as one quad face (two triangles once the reader splits it)
# and one more triangle, read by the built-in reader.
cat > "$work/quad.obj" <<'OBJ'
# a quad and a triangle
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
f 1 2 3 4
f 1 2 5
OBJ
"$build/examples/aacbvh-demo" --runs 1 --rays 64 --builders aac-fast "$work/quad.obj" \
    > "$work/demo.log" 2>&1 || { cat "$work/demo.log"; fail "aacbvh-demo on an OBJ file"; }
grep -Eq "^quad +3 +aac-fast " "$work/demo.log" ||
    { cat "$work/demo.log"; fail "aacbvh-demo did not read the 3 triangles of quad.obj"; }

step "cmake --install $build"
"$cmake" --install "$build" > "$work/install.log" 2>&1 || { cat "$work/install.log"; fail "install"; }
for f in include/aacbvh/aacbvh.h share/doc/aacbvh/LICENSE share/doc/aacbvh/CHANGELOG.md; do
    [ -f "$prefix/$f" ] || fail "$f not installed"
done
for pattern in 'libaacbvh.so.[0-9]*' aacbvh.pc aacbvhConfig.cmake aacbvhConfigVersion.cmake; do
    [ -n "$(find "$prefix" -name "$pattern" | head -n 1)" ] || fail "no $pattern installed under $prefix"
done
[ -f "$build/install_manifest.txt" ] || fail "no install_manifest.txt (README's uninstall uses it)"

# ---- 2. asking for the tests without cmocka fails, saying what to install ----
for option in BUILD_TESTING AACBVH_BUILD_TESTS; do
    step "configure with -D$option=ON and cmocka hidden must fail"
    # shellcheck disable=SC2086
    if "$cmake" -S "$src" -B "$work/build-$option" $compilers $hide -D$option=ON \
        > "$work/configure-$option.log" 2>&1; then
        cat "$work/configure-$option.log"
        fail "-D$option=ON configured without cmocka"
    fi
    # CMake wraps messages: compare with the lines joined.
    tr -s ' \n' '  ' < "$work/configure-$option.log" > "$work/configure-$option.txt"
    grep -q "apt-get install libcmocka-dev" "$work/configure-$option.txt" ||
        { cat "$work/configure-$option.log"; fail "the failure does not say to install libcmocka-dev"; }
    grep -q "CMOCKA_INCLUDE_DIR=CMOCKA_INCLUDE_DIR-NOTFOUND" "$work/configure-$option.txt" ||
        { cat "$work/configure-$option.log"; fail "cmocka was not hidden"; }
    rm -rf "$work/build-$option"
done

# ---- 3. inside another project, libaacbvh's tests and examples stay out ----
step "add_subdirectory from a project with include(CTest), cmocka hidden"
mkdir -p "$work/parent"
cat > "$work/parent/CMakeLists.txt" <<EOF
cmake_minimum_required(VERSION 3.16)
project(parent LANGUAGES C CXX)
include(CTest)
add_subdirectory("$src" aacbvh)
if(NOT TARGET aacbvh::aacbvh)
  message(FATAL_ERROR "no aacbvh::aacbvh target")
endif()
foreach(_target c-minimal aacbvh-demo aacbvh_test_support test_version)
  if(TARGET \${_target})
    message(FATAL_ERROR "libaacbvh's target \${_target} is part of the parent project")
  endif()
endforeach()
if(CMAKE_BUILD_TYPE)
  message(FATAL_ERROR "libaacbvh set the parent's CMAKE_BUILD_TYPE to \${CMAKE_BUILD_TYPE}")
endif()
EOF
# shellcheck disable=SC2086
"$cmake" -S "$work/parent" -B "$work/parent-build" $compilers $hide > "$work/parent.log" 2>&1 ||
    { cat "$work/parent.log"; fail "configuring a project that adds libaacbvh as a subdirectory"; }
grep -qx "BUILD_TESTING:BOOL=ON" "$work/parent-build/CMakeCache.txt" || fail "the parent's BUILD_TESTING is not ON"

echo "ok: configure, build and install without cmocka or tinyobjloader; tests asked for without cmocka fail with what to install; none of libaacbvh's tests or examples inside another project"
