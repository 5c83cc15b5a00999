#!/usr/bin/env bash
# The long fuzzing run of issue 15: scripts/fuzz.sh [RUNS] [JOBS]. Builds fuzz/'s target with
# cargo-fuzz on the nightly toolchain (installing both when missing) without a sanitizer, the
# fastest build (the target's own checks are the oracle: no panic, and a module `check` accepts
# validates), and runs JOBS libFuzzer processes (default 2) of RUNS/JOBS executions each over
# one corpus folder (default fuzz/corpus/check_and_lower). Each job logs to fuzz-N.log in the
# current folder; crashes are written to fuzz/artifacts/. Not part of CI: 10 million runs take
# about an hour on two cores.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
runs="${1:-10000000}"
jobs="${2:-2}"
corpus="${CORPUS:-$root/fuzz/corpus/check_and_lower}"
rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null 2>&1 || cargo install cargo-fuzz --locked
(cd "$root/fuzz" && cargo +nightly fuzz build -O -s none check_and_lower)
mkdir -p "$corpus" "$root/fuzz/artifacts"
exec "$root/fuzz/target/x86_64-unknown-linux-gnu/release/check_and_lower" "$corpus" \
    -runs=$((runs / jobs)) -jobs="$jobs" -workers="$jobs" -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$root/fuzz/artifacts/"
