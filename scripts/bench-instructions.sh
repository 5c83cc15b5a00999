#!/usr/bin/env bash
# Instructions lavapipe executes per frame for the composed and the hand-written raycaster of
# runtime/benches/render.rs: a deterministic companion to its wall-clock times, which vary
# between runs on a shared machine. Runs the bench under valgrind (callgrind) with lavapipe on
# the calling thread and its shader cache off, at 64x64, once with 1 and once with 3 timed
# frames; the difference over 2 is one frame.
# Usage: bash scripts/bench-instructions.sh
set -euo pipefail
cd "$(dirname "$0")/.."
VULKAN_ICD_PATTERN="lvp_icd*" source scripts/ensure-vulkan.sh
command -v valgrind >/dev/null || { apt-get update -qq && apt-get install -y -qq valgrind >/dev/null; }
bench=$(cargo bench -p vrs-runtime --bench render --no-run 2>&1 | grep -oP 'Executable benches/render.rs \(\K[^)]+')
export LP_NUM_THREADS=0 MESA_SHADER_CACHE_DISABLE=true VRS_ADAPTER=software VRS_BENCH_SIZE=64 VRS_BENCH_ROUNDS=1
count() { # shader, frames
    VRS_BENCH_ONLY=$1 VRS_BENCH_FRAMES=$2 valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bench" 2>&1 |
        grep -oP 'Collected : \K[0-9]+'
}
declare -A per_frame
for shader in composed hand-written; do
    one=$(count "$shader" 1)
    three=$(count "$shader" 3)
    per_frame[$shader]=$(((three - one) / 2))
    echo "$shader: $((per_frame[$shader] / 1000)) k instructions per 64x64 frame"
done
awk -v c="${per_frame[composed]}" -v h="${per_frame[hand-written]}" 'BEGIN { printf "composed / hand-written: %.3f\n", c / h }'
