#!/usr/bin/env bash
# Builds libaacbvh and runs the main job: every builder on every scene, timed
# (examples/aacbvh_demo.cpp). Arguments go to aacbvh-demo (try --help).
# Scenes: $AACBVH_SCENES, else ../shared/scenes beside the repository, else a
# generated scene. Idempotent: reruns reuse the build directory.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

require_tools cmake c++ cc make
log "configure and build (Release) in $AACBVH_BUILD_DIR"
configure "$AACBVH_BUILD_DIR" -DCMAKE_BUILD_TYPE=Release
cmake --build "$AACBVH_BUILD_DIR" -j "$AACBVH_JOBS" --target aacbvh-demo c-minimal

log "examples/c-minimal"
"$AACBVH_BUILD_DIR/examples/c-minimal"

log "aacbvh-demo $*"
"$AACBVH_BUILD_DIR/examples/aacbvh-demo" "$@"
