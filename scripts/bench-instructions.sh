#!/usr/bin/env bash
# Instructions lavapipe executes per frame: a deterministic companion to the benches' wall-clock
# times, which vary between runs on a shared machine. Runs a bench under valgrind (callgrind)
# with lavapipe on the calling thread and its shader cache off, at 64x64, once with 1 and once
# with 3 timed frames of one row; the difference over 2 is one frame. Ratios are to the first row.
# Usage: bash scripts/bench-instructions.sh
#            the composed and the hand-written raycaster of runtime/benches/render.rs
#        bash scripts/bench-instructions.sh bricks ROW...
#            rows of runtime/benches/bricks.rs (numbered as it prints them, early ray
#            termination off), e.g. `bricks 0 1 4`
set -euo pipefail
cd "$(dirname "$0")/.."
VULKAN_ICD_PATTERN="lvp_icd*" source scripts/ensure-vulkan.sh
command -v valgrind >/dev/null || { apt-get update -qq && apt-get install -y -qq valgrind >/dev/null; }
name=${1:-render}
if [ "$name" = render ]; then
    rows=(hand-written composed)
else
    rows=("${@:2}")
    export VRS_BENCH_NO_ERT=1
fi
[ ${#rows[@]} -gt 0 ] || { echo "usage: $0 [render | bricks ROW...]" >&2; exit 2; }
bench=$(cargo bench -p vrs-runtime --bench "$name" --no-run 2>&1 | grep -oP "Executable benches/$name.rs \(\K[^)]+")
export LP_NUM_THREADS=0 MESA_SHADER_CACHE_DISABLE=true VRS_ADAPTER=software VRS_BENCH_SIZE=64 VRS_BENCH_ROUNDS=1
count() { # row, frames
    VRS_BENCH_ONLY=$1 VRS_BENCH_FRAMES=$2 valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bench" 2>&1 |
        grep -oP 'Collected : \K[0-9]+'
}
first=""
for row in "${rows[@]}"; do
    one=$(count "$row" 1)
    three=$(count "$row" 3)
    per_frame=$(((three - one) / 2))
    first=${first:-$per_frame}
    awk -v r="$row" -v n="$per_frame" -v f="$first" \
        'BEGIN { printf "%s: %d k instructions per 64x64 frame, %.3f of the first\n", r, n / 1000, n / f }'
done
