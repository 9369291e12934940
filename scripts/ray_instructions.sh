#!/bin/sh
# Counts the instructions the default traversal runs per ray, the repeatable
# measure behind docs/PERFORMANCE.md rows 99-106 (wall time on a shared VM
# moves by more than most single changes). For each scene it runs
#
#   valgrind --tool=callgrind aacbvh-batch-threads --scenes SCENE --threads 1 --runs 1 --rays N --embree
#
# and, where the program was built with Embree 3, prints Embree's
# rtcIntersect1 and rtcOccluded1 per ray on the same rays beside ours
# (valgrind has no AVX-512, so Embree runs its AVX2 kernels there, as ours
# does; docs/PERFORMANCE.md, "Instructions per ray against Embree's").
#
# and prints the instructions of the 8-wide kernel's entry points (the one the
# CPU picked: wide8_avx2 on an AVX2 machine; valgrind has no AVX-512),
# inclusive of everything they call, for closest-hit rays (primary and
# diffuse together) and any-hit rays (shadow), through the batch entry
# points (which trace runs of eight coherent rays together where the kernel
# can), and the same per ray traced (from the ray counts in the program's
# log: an untimed pass and one timed run of each kind, and the primary rays
# once more for the secondary rays' origins). The
# counts depend on the compiler, the kernel and the tree, not on the machine's
# load: compare two builds on the same machine.
#
# Usage: scripts/ray_instructions.sh [BUILD_DIR] [SCENE ...]
#   BUILD_DIR  a Release build (default build-bench; configured and built
#              when needed)
#   SCENE      OBJ names in ../shared/scenes or paths (default: bunny.obj)
#   RAYS       environment: primary rays per side (default 192)
# Needs valgrind (apt-get install valgrind).
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-"$root/build-bench"}
[ $# -gt 0 ] && shift
case $build in /*) ;; *) build="$PWD/$build" ;; esac
rays=${RAYS:-192}
command -v valgrind > /dev/null || { echo "needs valgrind: apt-get install -y valgrind" >&2; exit 1; }

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$build" --target aacbvh-batch-threads -j2 > /dev/null

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
[ $# -gt 0 ] || set -- bunny.obj
printf '%-22s %14s %14s %10s %10s %14s %14s\n' scene "closest" "any hit" "per ray" "per ray" \
  "Embree closest" "Embree any hit"
for scene in "$@"; do
  valgrind --tool=callgrind --callgrind-out-file="$out/cg" "$build/examples/aacbvh-batch-threads" \
    --scenes "$scene" --threads 1 --runs 1 --rays "$rays" --embree > "$out/log" 2>&1
  # Closest-hit rays traced: primary and diffuse, each an untimed pass and
  # one timed run, and the primary rays once more for the secondary rays'
  # origins.
  closest_rays=$(awk '$2 == "primary" { n += 3 * $3 } $2 == "diffuse" { n += 2 * $3 } END { print n + 0 }' "$out/log")
  # Any-hit rays traced: the shadow rays, an untimed pass and one timed run.
  anyhit_rays=$(awk '$2 == "shadow" { n += 2 * $3 } END { print n + 0 }' "$out/log")
  # Each entry point's inclusive instructions, and its calls (Embree's: one
  # a ray), summed over its callers in the caller tree.
  callgrind_annotate --tree=caller --inclusive=yes --threshold=100 "$out/cg" 2> /dev/null |
    awk -v scene="$scene" -v closest_rays="$closest_rays" -v anyhit_rays="$anyhit_rays" '
      function ncalls(s,   k, parts, i, f) {
        k = split(s, parts, "(")
        for (i = k; i >= 1; i--)
          if (parts[i] ~ /^[0-9,]+x\)/) { f = parts[i]; sub(/x\).*/, "", f); gsub(",", "", f); return f + 0 }
        return 0
      }
      # The block now read: its calls (summed over the caller lines above
      # it) into s, its inclusive instructions into x; false without
      # callers (with debug info a function is listed once per source file
      # its lines come from; the block with callers is the whole function).
      function block(   i) {
        s = 0; for (i = 0; i < n; i++) s += calls[i]
        x = $1; gsub(",", "", x)
        return s > 0
      }
      /^ *$/ { n = 0; next }
      / < / { calls[n++] = ncalls($0); next }
      /\* .*wide8_[a-z0-9]+::.*(intersect|occluded)_batch_entry\(/ {
        if (!block()) next
        if ($0 ~ /intersect_batch_entry/) { c = x; cr = closest_rays } else { a = x; ar = anyhit_rays }
        next
      }
      # Embree entry points (exported), inclusive of its kernels.
      /\* .*rtc(Intersect|Occluded)1 / {
        if (!block()) next
        if ($0 ~ /rtcIntersect1/) { ec = x; ecr = s } else { ea = x; ear = s }
      }
      END {
        if (!c || !cr) { printf "%-22s no 8-wide entry points counted (symbols stripped?)\n", scene; exit 1 }
        printf "%-22s %14d %14d %10.0f %10.0f", scene, c, a, c / cr, (ar ? a / ar : 0)
        if (ecr) printf " %14.0f %14.0f", ec / ecr, (ear ? ea / ear : 0)
        else printf " %14s %14s", "n/a", "n/a"
        printf "\n"
      }'
done
