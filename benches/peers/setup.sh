#!/usr/bin/env bash
# Sets up the Python environment of the peer benchmark: pygfx 0.17 (wgpu-py, which finds
# lavapipe through Vulkan) and VTK 9.7 (its PyPI wheel renders offscreen through EGL; with no
# GPU, Mesa's llvmpipe). Also builds the vrsc contender (the runtime's `peer_worker` example).
# Usage: bash benches/peers/setup.sh   (creates benches/peers/.venv, or $PEERS_VENV)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="${PEERS_VENV:-$here/.venv}"
# Vulkan (lavapipe) and EGL (llvmpipe): installed when the machine has no Vulkan driver.
source "$root/scripts/ensure-vulkan.sh"
python3 -m venv "$venv"
"$venv/bin/pip" install -q --upgrade pip
"$venv/bin/pip" install -q "pygfx==0.17.*" "vtk==9.7.*" numpy imageio
"$venv/bin/python" -c "import pygfx, vtk, wgpu; print('pygfx', pygfx.__version__, '| vtk', vtk.vtkVersion.GetVTKVersion(), '| wgpu-py', wgpu.__version__)"
(cd "$root" && cargo build --release -p vrs-runtime --example peer_worker -p vrsc-cli)
echo "ready: $venv/bin/python $here/run.py --help"
