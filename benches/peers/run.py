"""The peer benchmark: vrsc against VTK's GPU ray-cast mapper and pygfx's volume raycaster, and
against a vrsc from before a change, on the same volume, camera, transfer function, image size
and step along the ray. Each contender is a long-lived process; within a case they take turns
round by round, so a slow spell of a shared machine hits them alike. Prints median frame times,
each contender's time over vrsc's, nominal samples per second and the mean image difference to
vrsc. See README.md beside this file. Not part of CI.
"""

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
MNI_T1 = ROOT / "../shared/data/mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz"

# The camera of every case: vrsc's orbit camera (runtime/src/geometry.rs).
CAMERA = {"azimuth": 30.0, "elevation": 20.0, "distance": 2.5, "fov": 30.0}
# Opacities are defined per this distance (vrsc's `ref_step`, VTK's unit distance).
REF_STEP = 0.0025
# What each mode means to each contender.
MODES = {
    "dvr": {"compositing": "dvr", "shading": False},
    "dvr_shaded": {"compositing": "dvr", "shading": True},
    "mip": {"compositing": "mip", "shading": False},
}
# The writer of `contributes` per compositing mode (stdlib), for the `noflag` variant. MIP has
# none: its `selected` flag defines which sample is composited (removing it changes the image).
FLAG_WRITERS = {
    "dvr": "remove shading.lights[dvr_contributes];",
}
# Variants of the vrsc under test: a line added to [render], and a module (per compositing).
VARIANTS = {
    "noskip": ("empty_space_skipping = false", None),
    "noflag": (None, lambda mode: FLAG_WRITERS.get(MODES[mode]["compositing"])),
    "onefetch": (None, lambda mode: ONE_FETCH_GRADIENT if MODES[mode]["shading"] else None),
}
# Not a gradient (the image differs): one fetch where the gradient takes six, the floor of
# any gradient kept in a texture (shaded modes only).
ONE_FETCH_GRADIENT = """pipeline one_fetch_gradient replace sampling.gradient[sample_gradient] {
    uniform volume: volume;
    state pos: vec3f = vec3f(0.0);
    state gradient: vec3f = vec3f(0.0);
    state.gradient = vec3f(sample(volume, state.pos + vec3f(0.001)) - 0.5, 0.5, 0.5);
}"""
VOLUMES = {
    # The MNI152 T1 (uint8 MRI, 197 x 233 x 189 at 1 mm) with the MR preset over its automatic
    # window; the head phantom at 256^3 in Hounsfield units with the bone preset.
    "mni_t1": {"volume": {"file": str(MNI_T1)}, "tf": "mr_default", "window": None},
    "phantom256": {"volume": {"phantom": "head", "size": 256}, "tf": "ct_bone", "window": None},
    # The T1 under a linear ramp over its whole range (0-255): grey, opacity 0 to 0.05 per
    # reference step (visible_ramp.json), so every sample but the air's is visible and shaded and
    # few rays end early: the case where shading's cost shows.
    "mni_t1_ramp": {"volume": {"file": str(MNI_T1)}, "tf": str(HERE / "visible_ramp.json"), "window": [0.0, 255.0]},
}


class Worker:
    """A contender's process, spoken to in JSON lines."""

    def __init__(self, name, argv, env=None):
        self.name = name
        self.process = subprocess.Popen(
            argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env, cwd=HERE
        )

    def ask(self, **request):
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f"{self.name} ended")
        answer = json.loads(line)
        if "error" in answer:
            raise RuntimeError(f"{self.name}: {answer['error']}")
        return answer

    def close(self):
        self.process.stdin.close()
        self.process.wait(timeout=60)


def pygfx_step(dims):
    """pygfx 0.17's step along the ray (volume_ray.wgsl): clamp(sqrt(largest dim) / 20, 0.1,
    0.8) voxels, here in units of the box's largest side, which every contender is given."""
    n = max(dims)
    return min(max(math.sqrt(n) / 20.0, 0.1), 0.8) / n


def nominal_samples(case):
    """Samples per frame without early termination or skipping: ceil((exit - entry) / step) per
    pixel, in the normalized coordinates vrsc marches in."""
    w, h = case["size"]
    extent = np.array(case["extent"], dtype=np.float64)
    scale = extent / extent.max()
    eye = np.array(
        [
            CAMERA["distance"] * math.sin(math.radians(CAMERA["azimuth"])) * math.cos(math.radians(CAMERA["elevation"])),
            CAMERA["distance"] * math.cos(math.radians(CAMERA["azimuth"])) * math.cos(math.radians(CAMERA["elevation"])),
            CAMERA["distance"] * math.sin(math.radians(CAMERA["elevation"])),
        ]
    )
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan = math.tan(math.radians(CAMERA["fov"]) / 2)
    xs = ((np.arange(w) + 0.5) / w * 2 - 1) * tan * (w / h)
    ys = (1 - (np.arange(h) + 0.5) / h * 2) * tan
    dirs = forward + xs[None, :, None] * right + ys[:, None, None] * up
    dirs = dirs / scale
    dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
    origin = eye / scale + 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / dirs
        t0 = (0 - origin) * inv
        t1 = (1 - origin) * inv
    entry = np.maximum(np.minimum(t0, t1).max(axis=-1), 0)
    exit_ = np.maximum(t0, t1).min(axis=-1)
    hit = exit_ > entry
    return float(np.ceil((exit_[hit] - entry[hit]) / case["step"]).sum())


def scene_toml(case, volume):
    mode = MODES[case["mode"]]
    source = volume["volume"]
    source_line = f'path = "{source["file"]}"' if "file" in source else f'phantom = "{source["phantom"]}"'
    lo, hi = case["window"]
    lights = 'lights = ["key"]\n' if mode["shading"] else ""
    return f"""# Written by benches/peers/run.py
[render]
compositing = "{mode['compositing']}"
shading = {str(mode['shading']).lower()}
{lights}jitter = 0.0
step_size = {case['step'] * max(case['extent'])!r}

[[volume]]
name = "primary"
role = "primary"
{source_line}
tf = "{volume['tf']}"
window = [{lo!r}, {hi!r}]

[[view]]
name = "3d"
kind = "raycast"
size = [{case['size'][0]}, {case['size'][1]}]
camera = {{ azimuth = {CAMERA['azimuth']}, elevation = {CAMERA['elevation']}, distance = {CAMERA['distance']}, fov = {CAMERA['fov']} }}
"""


def build(vrsc, scene, out):
    result = subprocess.run([str(vrsc), "build", str(scene), "-o", str(out)], capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{vrsc} build {scene}: {result.stderr}")


def read_image(path):
    if path.suffix == ".npy":
        return np.load(path).astype(np.float64)
    import imageio.v3 as iio

    return iio.imread(path)[:, :, :3].astype(np.float64)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--vrsc", default=str(ROOT / "target/release/vrsc"), help="the vrsc that composes")
    parser.add_argument("--before", help="another vrsc binary (e.g. from before a change), a contender too")
    parser.add_argument(
        "--before-units",
        choices=["normalized", "mm"],
        default="normalized",
        help="the units --before takes step sizes in: normalized (a vrsc from before physical sampling, "
        "the default) or mm (a vrsc with physical sampling and `[[volume]] window`)",
    )
    parser.add_argument("--worker", default=str(ROOT / "target/release/examples/peer_worker"))
    parser.add_argument("--volumes", default="mni_t1,phantom256")
    parser.add_argument("--modes", default="dvr,dvr_shaded,mip")
    parser.add_argument("--sizes", default="512,256")
    parser.add_argument(
        "--contenders",
        default="vrsc,noskip,bricked,before,vtk,pygfx",
        help="vrsc, before (--before's shaders), vtk, pygfx, and the variants of vrsc: noskip (empty-space "
        "skipping off), noflag (the writer of `contributes` removed: every function runs for every sample), "
        "onefetch (shaded modes: the gradient replaced by one fetch, the floor of a gradient texture), "
        "bricked (the volume kept in bricks, every brick resident: compare with noskip, as bricked volumes "
        "skip no empty space)",
    )
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--frames", type=int, default=1, help="timed frames per round and contender")
    parser.add_argument("--out", help="folder for scenes, shaders and images (default: a temporary one)")
    args = parser.parse_args()

    out = Path(args.out or tempfile.mkdtemp(prefix="vrs-peers-"))
    out.mkdir(parents=True, exist_ok=True)
    wanted = args.contenders.split(",")
    if not args.before:
        wanted = [c for c in wanted if c != "before"]
    env = dict(os.environ, PYTHONPATH=str(HERE))
    # The Vulkan loader prints an error on every start without a valid runtime folder.
    if not os.path.isdir(env.get("XDG_RUNTIME_DIR", "")):
        env["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="vrs-peers-runtime-")
    python = sys.executable
    workers = {"vrsc": Worker("vrsc", [args.worker], env)}
    if "vtk" in wanted:
        workers["vtk"] = Worker("vtk", [python, str(HERE / "vtk_worker.py")], env)
    if "pygfx" in wanted:
        workers["pygfx"] = Worker("pygfx", [python, str(HERE / "pygfx_worker.py")], env)
    print(f"output: {out}")
    print(f"vrsc: {args.vrsc}" + (f"; before: {args.before}" if args.before else ""))
    print(f"{'case':<28} {'contender':<10} {'ms/frame':>9} {'/ vrsc':>7} {'M samples/s':>12} {'mean |diff|':>11}")

    rows = []
    for volume_name in args.volumes.split(","):
        volume = VOLUMES[volume_name]
        if "file" in volume["volume"] and not Path(volume["volume"]["file"]).exists():
            print(f"{volume_name}: {volume['volume']['file']} is absent, skipped")
            continue
        prepared_dir = out / volume_name
        prepared = workers["vrsc"].ask(
            cmd="prepare", volume=volume["volume"], window=volume["window"], tf=volume["tf"], out=str(prepared_dir)
        )
        for mode in args.modes.split(","):
            for size in [int(s) for s in args.sizes.split(",")]:
                case = {
                    "dir": str(prepared_dir),
                    "dims": prepared["dims"],
                    "extent": prepared["extent"],
                    "window": prepared["window"],
                    "mode": mode,
                    "size": [size, size],
                    "camera": CAMERA,
                    "step": pygfx_step(prepared["dims"]),
                    "ref_step": REF_STEP,
                }
                rows += run_case(f"{volume_name}/{mode}/{size}", case, volume, workers, wanted, args, out)
    for worker in workers.values():
        worker.close()
    (out / "results.json").write_text(json.dumps(rows, indent=1))
    print(f"results: {out / 'results.json'}")


def run_case(label, case, volume, workers, wanted, args, out):
    folder = out / label.replace("/", "_")
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / "scene.toml"
    scene.write_text(scene_toml(case, volume))
    max_samples = math.ceil(math.sqrt(3.0) / case["step"]) + 2
    # vrsc's `step_size` and `ref_step` are millimetres in patient space: the step and the
    # reference distance as fractions of the box's largest side, times that side. A vrsc from
    # before physical sampling (`before`) takes them as those fractions (normalized units).
    side_mm = max(case["extent"])
    uniforms = {
        "step_size": case["step"] * side_mm,
        "ref_step": case["ref_step"] * side_mm,
        "jitter": 0.0,
        "max_samples": max_samples,
    }
    physical_before = args.before_units == "mm"
    before_uniforms = uniforms if physical_before else dict(uniforms, step_size=case["step"], ref_step=case["ref_step"])
    shaders = {"vrsc": folder / "vrsc"}
    build(args.vrsc, scene, shaders["vrsc"])
    # Variants of this vrsc, to measure what each mechanism is worth.
    for name, (render_line, module) in VARIANTS.items():
        if name not in wanted:
            continue
        item = module(case["mode"]) if module else None
        if module and item is None:
            continue
        text = scene.read_text()
        if render_line:
            text = text.replace("[render]\n", f"[render]\n{render_line}\n", 1)
        if item:
            (folder / f"{name}.vrs").write_text(item + "\n")
            text += f'\n[[module]]\npath = "{name}.vrs"\n'
        variant = folder / f"{name}.toml"
        variant.write_text(text)
        shaders[name] = folder / name
        build(args.vrsc, variant, shaders[name])
    if "before" in wanted:
        shaders["before"] = folder / "before"
        # Only the shaders come from it; the worker opens the volume with today's runtime. A
        # vrsc from before `[[volume]] window` existed builds the scene without that key.
        before_scene = folder / "before.toml"
        lines = scene.read_text().splitlines(True)
        if not physical_before:
            lines = [l for l in lines if not l.startswith("window = ")]
            lines = [f"step_size = {case['step']!r}\n" if l.startswith("step_size = ") else l for l in lines]
        before_scene.write_text("".join(lines))
        build(args.before, before_scene, shaders["before"])
    phantom = volume["volume"].get("size", 128)
    workers["vrsc"].ask(cmd="open", scene=str(scene), size=case["size"], phantom_size=phantom)
    # The same scene with the volume in bricks, opened as its own scene: the worker renders it
    # with the shader its runtime composes and streams every brick in before it answers.
    own_scenes = set()
    if "bricked" in wanted:
        bricked = folder / "bricked.toml"
        text = scene.read_text().replace('role = "primary"\n', 'role = "primary"\nbricks = true\n', 1)
        bricked.write_text(text)
        workers["vrsc"].ask(cmd="open", scene=str(bricked), size=case["size"], phantom_size=phantom, **{"as": "bricked"})
        own_scenes.add("bricked")

    # Set up every contender that renders this mode.
    active = []
    for name in wanted:
        if name in shaders or name in own_scenes:
            active.append(name)
        elif name in workers:
            try:
                workers[name].ask(cmd="setup", **case)
                active.append(name)
            except RuntimeError as error:
                if "no emission-absorption" not in str(error):
                    print(f"{label}: {name} left out: {error}")

    def uniforms_of(name):
        return before_uniforms if name == "before" else uniforms

    def vrsc_request(name, cmd):
        """A request to the vrsc worker for contender `name`: one of its shaders, or a scene of its own."""
        request = dict(cmd=cmd, view="3d", uniforms=uniforms_of(name))
        if name in own_scenes:
            return dict(request, scene=name)
        return dict(request, shader=str(shaders[name]))

    def time_frames(name, warmup):
        if name in shaders or name in own_scenes:
            return workers["vrsc"].ask(**vrsc_request(name, "time"), frames=args.frames, warmup=warmup)["ms"]
        return workers[name].ask(cmd="time", frames=args.frames, warmup=warmup)["ms"]

    def image(name):
        if name in shaders or name in own_scenes:
            path = folder / f"{name}.png"
            workers["vrsc"].ask(**vrsc_request(name, "image"), out=str(path))
        else:
            path = folder / f"{name}.npy"
            workers[name].ask(cmd="image", out=str(path))
        return read_image(path)

    images = {name: image(name) for name in active}
    times = {name: [] for name in active}
    for round_ in range(args.rounds):
        for name in active:
            # One untimed frame before a contender's first turn (pipelines, caches).
            times[name] += time_frames(name, warmup=round_ == 0)
    samples = nominal_samples(case)
    reference = statistics.median(times["vrsc"])
    rows = []
    for name in active:
        ms = statistics.median(times[name])
        diff = float(np.abs(images[name] - images["vrsc"]).mean())
        row = {
            "case": label,
            "contender": name,
            "ms": ms,
            "over_vrsc": ms / reference,
            "samples_per_frame": samples,
            "msamples_per_s": samples / ms / 1e3,
            "mean_abs_diff": diff,
            "times": times[name],
        }
        rows.append(row)
        print(
            f"{label:<28} {name:<10} {ms:9.1f} {ms / reference:7.2f} {row['msamples_per_s']:12.1f} {diff:11.2f}",
            flush=True,
        )
    if "bricked" in times and "noskip" in times:
        # What bricks cost: both skip no empty space.
        over = statistics.median(times["bricked"]) / statistics.median(times["noskip"])
        print(f"{label:<28} bricked over noskip: {over:.2f}x", flush=True)
    return rows


if __name__ == "__main__":
    started = time.time()
    main()
    print(f"took {time.time() - started:.0f} s")
