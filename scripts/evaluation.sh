#!/bin/sh
# Regenerates docs/EVALUATION.md (and docs/evaluation.{csv,json,svg}) from one run
# of the evaluation benchmark over every OBJ in ../shared/scenes and the
# generated scene (the issues' targets name both), every builder, and Embree
# when the build found it. The commands it runs:
#
#   aacbvh-bench --scenes shared,procedural --runs 5 --rays 256 --threads 1,2 \
#       --csv docs/evaluation.csv --json docs/evaluation.json \
#       --markdown docs/EVALUATION.md
#   aacbvh-bench --replot docs/evaluation.json --svg docs/evaluation.svg
#
# To redraw the plot (or the other outputs) from the last run's data, without
# running the benchmark: aacbvh-bench --replot docs/evaluation.json --svg docs/evaluation.svg
#
# Usage: scripts/evaluation.sh [BUILD_DIR] [extra aacbvh-bench options]
# BUILD_DIR defaults to build-bench; it is configured and built when needed.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-"$root/build-bench"}
[ $# -gt 0 ] && shift
case $build in /*) ;; *) build="$PWD/$build" ;; esac

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$build" --target aacbvh-bench -j2

cd "$root"
mkdir -p docs
"$build/examples/aacbvh-bench" --scenes shared,procedural --runs 5 --rays 256 --threads 1,2 \
  --csv docs/evaluation.csv --json docs/evaluation.json \
  --markdown docs/EVALUATION.md "$@"
# The plot from the JSON file, as the replot test (bench_replot_svg_current)
# makes it: the JSON keeps six decimals, and a label placed from unrounded
# figures can land elsewhere when two labels nearly meet.
"$build/examples/aacbvh-bench" --replot docs/evaluation.json --svg docs/evaluation.svg
