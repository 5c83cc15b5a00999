"""The pygfx contender: its volume raycaster (a fragment shader over the volume's box) on an
offscreen canvas, through wgpu-py on the Vulkan adapter (lavapipe without a GPU). A frame is
`canvas.draw()`, which renders and reads the image back (about 1 MB at 512x512)."""

import time

import numpy as np
import pygfx as gfx
import wgpu
from rendercanvas.offscreen import RenderCanvas

import peers_common as common

state = {}


def pick_adapter():
    """The Vulkan adapter (lavapipe here) rather than the GL one wgpu-py also lists."""
    adapters = wgpu.gpu.enumerate_adapters_sync()
    vulkan = [a for a in adapters if "Vulkan" in a.summary]
    if vulkan:
        gfx.renderers.wgpu.select_adapter(vulkan[0])
        return vulkan[0].summary
    return adapters[0].summary if adapters else "none"


def setup(case):
    if case["mode"] != "mip":
        raise ValueError("pygfx 0.17 has no emission-absorption (DVR) volume material")
    volume, tf = common.load_prepared(case)
    scale, spacing, origin = common.world_box(case)
    if "adapter" not in state:
        state["adapter"] = pick_adapter()
    canvas = RenderCanvas(size=tuple(case["size"]), pixel_ratio=1)
    renderer = gfx.WgpuRenderer(canvas)
    scene = gfx.Scene()
    scene.add(gfx.Background.from_color("#000000"))
    grid = gfx.Texture(volume.astype(np.float16), dim=3)
    colormap = gfx.TextureMap(gfx.Texture(tf.astype(np.float32), dim=1), filter="linear")
    material = gfx.VolumeMipMaterial(clim=(0.0, 1.0), map=colormap, interpolation="linear")
    mesh = gfx.Volume(gfx.Geometry(grid=grid), material)
    mesh.local.scale = tuple(spacing)
    mesh.local.position = tuple(origin)
    scene.add(mesh)
    camera = gfx.PerspectiveCamera(case["camera"]["fov"], 1.0, depth_range=(0.05, 20.0))
    camera.local.position = common.eye_position(case["camera"])
    camera.world.reference_up = (0, 0, 1)
    camera.look_at((0, 0, 0))
    canvas.request_draw(lambda: renderer.render(scene, camera))
    state.update(canvas=canvas, renderer=renderer, scene=scene, camera=camera)
    canvas.draw()
    return {"ok": True, "adapter": state["adapter"]}


def frame():
    canvas = state["canvas"]
    start = time.perf_counter()
    canvas.request_draw(lambda: state["renderer"].render(state["scene"], state["camera"]))
    canvas.draw()
    return (time.perf_counter() - start) * 1e3


def timed(request):
    if request.get("warmup", True):
        frame()
    return {"ms": [frame() for _ in range(request["frames"])]}


def image(request):
    canvas = state["canvas"]
    canvas.request_draw(lambda: state["renderer"].render(state["scene"], state["camera"]))
    pixels = np.asarray(canvas.draw())
    np.save(request["out"], pixels[:, :, :3].copy())
    return {"ok": True}


common.serve({"setup": setup, "time": timed, "image": image})
