#!/bin/sh
# Packs what a many-core measurement needs into .devkit/ (ignored by git), so
# that a borrowed machine with no network and no compiler for this project
# can run it: the Release benchmarks and their libraries (ours, Debian's
# Embree 3 and TBB, tinyobjloader), the kernel tests that force each
# kernel (so a CPU with AVX-512 runs the AVX-512 combines), the scenes
# gzipped (about 15 MB for ../shared/scenes), and .devkit/run.sh, which
# unpacks them in /tmp and runs, with its output in $OUT (default
# /tmp/many-core):
#
#   lscpu and the AVX-512 flags; the kernel tests;
#   aacbvh-bench: builds at THREADS (default 1,2,4,8,16), AAC-HQ, AAC-Fast,
#     AAC-HQ + 4 optimisation passes, Embree MEDIUM and LOW, fresh memory;
#   aacbvh-build-phases: where the time goes at each count, fresh and kept memory;
#   aacbvh-bench: rays on one thread against Embree's scene;
#   aacbvh-batch-threads: ray batches at each count.
#
# docs/PERFORMANCE.md "Builds on 16 cores" came from such a run. The run
# takes about 5 minutes on two threads here (1,2), so give a 16-core machine
# about 8. Compare only the figures of one run (one machine), and name its
# CPU with them.
#
# Usage: scripts/many_core_kit.sh [BUILD_DIR]   (default build-bench, Release;
#        configured and built when needed), then on the other machine, from
#        the repository root: THREADS=1,4,16 sh .devkit/run.sh
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-"$root/build-bench"}
case $build in /*) ;; *) build="$PWD/$build" ;; esac
scenes="$root/../shared/scenes"
kit="$root/.devkit"

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$build" -j2 --target aacbvh-bench aacbvh-batch-threads aacbvh-build-phases \
  test_cluster_kernels test_trace_kernels test_determinism test_build_invariants > /dev/null

rm -rf "$kit"
mkdir -p "$kit/bin" "$kit/lib" "$kit/tests" "$kit/scenes"
for p in aacbvh-bench aacbvh-batch-threads aacbvh-build-phases; do cp "$build/examples/$p" "$kit/bin/"; done
for t in test_cluster_kernels test_trace_kernels test_determinism test_build_invariants; do
  cp "$build/tests/$t" "$kit/tests/"
done
cp -L "$build/capi/libaacbvh.so.1" "$kit/lib/"
# The other libraries the programs load, as this machine has them (the big
# Embree library gzipped: about 16 MB instead of 44).
for p in "$kit"/bin/* "$kit"/tests/*; do ldd "$p"; done | awk '$3 ~ /^\// {print $1, $3}' | sort -u |
  while read -r name path; do
    case $name in
      libaacbvh*|libc.so*|libm.so*|libstdc++*|libgcc_s*|ld-linux*) ;;
      libembree3*) gzip -c "$path" > "$kit/lib/$name.gz" ;;
      *) cp -L "$path" "$kit/lib/$name" ;;
    esac
  done
if [ -d "$scenes" ]; then
  for s in "$scenes"/*.obj; do gzip -c "$s" > "$kit/scenes/$(basename "$s").gz"; done
fi

cat > "$kit/run.sh" << 'EOF'
#!/bin/sh
# Written by scripts/many_core_kit.sh; see there.
kit=$(cd "$(dirname "$0")" && pwd)
threads=${THREADS:-1,2,4,8,16}
out=${OUT:-/tmp/many-core}
mkdir -p "$out" /tmp/many-core-kit/lib /tmp/many-core-kit/scenes
exec > "$out/log.txt" 2>&1
date -u
lscpu | grep -E "Model name|^CPU\(s\)|Thread|Core|Socket|L3|NUMA node\(s\)"
echo "avx512: $(grep -o 'avx512[a-z0-9_]*' /proc/cpuinfo | sort -u | tr '\n' ' ')"
cp "$kit"/lib/*.so* /tmp/many-core-kit/lib/
for z in "$kit"/lib/*.gz; do [ -f "$z" ] && gzip -dc "$z" > "/tmp/many-core-kit/lib/$(basename "$z" .gz)"; done
for z in "$kit"/scenes/*.gz; do [ -f "$z" ] && gzip -dc "$z" > "/tmp/many-core-kit/scenes/$(basename "$z" .gz)"; done
export LD_LIBRARY_PATH=/tmp/many-core-kit/lib
list=$(ls /tmp/many-core-kit/scenes/*.obj 2> /dev/null | tr '\n' ',' | sed 's/,$//')
[ -n "$list" ] || list=procedural
echo "== kernel tests"
for t in "$kit"/tests/*; do echo "-- $(basename "$t")"; timeout 120 "$t" 2>&1 | grep -E "kernels|PASSED|FAILED"; done
echo "== builds, threads $threads"
timeout 300 "$kit/bin/aacbvh-bench" --scenes "$list" --builders aac-hq,aac-fast,aac-hq+opt4,embree-medium,embree-low \
  --threads "$threads" --runs 5 --views 0 --rays 64 --json "$out/builds.json" | grep -v '^\['
echo "== phases, fresh memory"
timeout 200 "$kit/bin/aacbvh-build-phases" --scenes "$list" --threads "$threads" --runs 7
echo "== phases, kept memory"
timeout 200 "$kit/bin/aacbvh-build-phases" --scenes "$list" --threads "$threads" --runs 7 --keep-build-memory
echo "== rays, one thread"
timeout 200 "$kit/bin/aacbvh-bench" --scenes "$list" --builders aac-hq,embree-scene --runs 5 --views 0 --rays 256 \
  --json "$out/rays.json" | grep -v '^\['
echo "== ray batches, threads $threads"
timeout 200 "$kit/bin/aacbvh-batch-threads" --scenes "$list" --threads "$threads" --runs 3
date -u
EOF
chmod +x "$kit/run.sh"
du -sh "$kit"
