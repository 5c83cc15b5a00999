"""Rendering a large volume many times does not grow the process: the array is uploaded once
and shared by every render, and nothing per render is kept."""

import sys

import numpy as np
import pytest

import vrsc

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/status")


def resident_mib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def test_rendering_a_256_cubed_float32_volume_100_times_does_not_grow_the_process():
    z, y, x = np.ogrid[-1:1:256j, -1:1:256j, -1:1:256j]
    volume = np.clip(1.0 - np.sqrt(x * x + y * y + z * z), 0.0, None).astype(np.float32)
    assert volume.shape == (256, 256, 256) and volume.nbytes == 64 << 20
    scene = vrsc.Scene.from_array(volume)
    for _ in range(5):  # warm-up: pipelines, the driver's caches
        scene.render(size=(32, 32))
    before = resident_mib()
    for _ in range(100):
        image = scene.render(size=(32, 32))
    after = resident_mib()
    print(f"\nresident after 5 renders {before:.1f} MiB, after 100 more {after:.1f} MiB")
    assert image.shape == (32, 32, 4)
    assert after - before < 8, f"grew {after - before:.1f} MiB over 100 renders"


def test_scenes_made_again_and_again_from_one_array_do_not_accumulate():
    volume = np.random.default_rng(1).random((128, 128, 128), dtype=np.float32)
    for _ in range(3):
        vrsc.Scene.from_array(volume).render(size=(16, 16))
    before = resident_mib()
    for _ in range(10):
        vrsc.Scene.from_array(volume).render(size=(16, 16))
    after = resident_mib()
    print(f"\nresident after 3 scenes {before:.1f} MiB, after 10 more {after:.1f} MiB")
    # One scene's texture is 4 MiB: ten kept would be 40.
    assert after - before < 16, f"grew {after - before:.1f} MiB over 10 scenes"
