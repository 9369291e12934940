#!/bin/sh
# The C program shown in README.md must be examples/c-minimal.c, which the
# build compiles and the tests run, so the README's example cannot rot.
# usage: check_readme_example.sh README C_FILE
set -eu
awk '/^```c$/ { inside = 1; next } inside && /^```$/ { exit } inside { print }' "$1" |
    diff -u "$2" - && echo "ok: the C example in $(basename "$1") is $(basename "$2")"
