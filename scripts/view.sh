#!/usr/bin/env bash
# Opens a scene in the viewer: scripts/view.sh [SCENE]. Edit the scene or its modules in any
# editor and the window follows. Installs the software Vulkan driver first when the machine has
# no Vulkan driver at all. Without a display (a server, CI) it says so and renders the scene
# headless to out/ instead, the command that works anywhere.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-vulkan.sh
scene="${1:-examples/ablation/scene.toml}"
if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
    echo "no display (DISPLAY and WAYLAND_DISPLAY are unset): rendering $scene to out/ instead" >&2
    exec cargo run --release --bin vrsc -- render "$scene" -o out
fi
. scripts/ensure-window.sh
exec cargo run --release --bin vrsc -- view "$scene"
