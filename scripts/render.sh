#!/usr/bin/env bash
# Renders a scene to PNG images: scripts/render.sh [SCENE] [OUT_DIR]. Installs the software
# Vulkan driver first when the machine has no Vulkan driver at all.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-vulkan.sh
scene="${1:-examples/ablation/scene.toml}"
out="${2:-out}"
cargo run --release --bin vrsc -- render "$scene" -o "$out"
