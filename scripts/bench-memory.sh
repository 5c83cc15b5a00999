#!/usr/bin/env bash
# Peak resident memory of loading and rendering a large int16 volume:
#   bash scripts/bench-memory.sh [SIZE_Z]
# Writes a 256 x 256 x SIZE_Z (default 500: 65.5 MB of data) int16 NRRD of a smooth pattern and
# a one-view scene in a temporary folder, renders it once with the release `vrsc` at 64x64
# under `/usr/bin/time -v` with empty-space skipping on (the default) and off, and prints the
# data size and the peak resident set size of each. The
# volume's own memory is the file's data plus the GPU's copy (on lavapipe, the texture lives in
# system memory too); everything else is the process (Vulkan driver, shader compiler).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-vulkan.sh
nz="${1:-500}"
cargo build --release --bin vrsc >/dev/null
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
python3 - "$tmp/ct.nrrd" "$nz" <<'EOF'
import array, math, sys
path, nz = sys.argv[1], int(sys.argv[2])
nx = ny = 256
with open(path, "wb") as f:
    f.write(b"NRRD0004\ntype: short\ndimension: 3\nspace: left-posterior-superior\n")
    f.write(f"sizes: {nx} {ny} {nz}\nspace directions: (0.7,0,0) (0,0.7,0) (0,0,1.25)\n".encode())
    f.write(b"endian: little\nencoding: raw\nspace origin: (0,0,0)\n\n")
    # A sphere of "soft tissue" (40 HU) with a "bone" shell (1000 HU) in "air" (-1000 HU); each
    # row is three runs, so it is written by slices rather than voxel by voxel.
    def run(row, c, radius, value):
        if c < radius * radius:
            h = math.sqrt(radius * radius - c)
            lo, hi = max(0, math.ceil(128 - h)), min(nx, math.floor(128 + h) + 1)
            row[lo:hi] = array.array("h", [value] * max(0, hi - lo))
    for z in range(nz):
        for y in range(ny):
            row = array.array("h", [-1000] * nx)
            c = (y - 128) ** 2 + ((z - nz / 2) * 1.8) ** 2
            run(row, c, 100, 1000)
            run(row, c, 90, 40)
            f.write(row.tobytes())
EOF
# Two scenes: the default (empty-space skipping on: the primary volume's brick ranges are taken
# from the texels as they are uploaded) and skipping off.
write_scene() {
    cat > "$tmp/$1.toml" <<EOF2
[render]
empty_space_skipping = $2

[[volume]]
name = "ct"
role = "primary"
path = "ct.nrrd"

[[view]]
name = "3d"
kind = "raycast"
EOF2
}
write_scene skipping true
write_scene no_skipping false
bytes=$(stat -c %s "$tmp/ct.nrrd")
echo "volume file: $((bytes / 1000000)) MB ($bytes bytes, 256x256x$nz int16)"
for scene in skipping no_skipping; do
    /usr/bin/time -v target/release/vrsc render "$tmp/$scene.toml" -o "$tmp/out" --size 64x64 2>"$tmp/time.txt" >/dev/null
    peak_kb=$(grep "Maximum resident set size" "$tmp/time.txt" | awk '{print $NF}')
    echo "peak resident memory, $scene: $((peak_kb / 1024)) MiB ($peak_kb KiB)"
done
