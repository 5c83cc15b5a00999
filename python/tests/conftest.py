"""Shared set-up: rendering on the software adapter (the same pictures on every machine, as the
runtime's own tests), and small volumes."""

import os
import tempfile

import numpy as np
import pytest

os.environ.setdefault("VRS_ADAPTER", "software")
if not os.environ.get("XDG_RUNTIME_DIR"):
    os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="vrsc-xdg-")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

TINT = """
/// Tints every classified sample.
pipeline tint after classification.primary {
    uniform tint: vec3f = vec3f(1.0, 0.5, 0.25) in 0.0 .. 1.0;
    uniform boost: f32 = 1.0 in 0.0 .. 4.0;
    uniform steps: i32 = 1;
    uniform enabled: bool = true;
    state color: vec4f;
    if enabled {
        state.color = vec4f(state.color.rgb * tint * boost, state.color.a);
    }
}
"""


def ball(n=32, dtype=np.float32):
    """A ball bright at its centre, fading to its surface, in an n^3 grid; not symmetric along
    x (a step on the right half) so axis mix-ups change the picture."""
    z, y, x = np.mgrid[-1 : 1 : n * 1j, -1 : 1 : n * 1j, -1 : 1 : n * 1j]
    # mgrid's first index is the array's first axis: call it x.
    x, z = z, x
    values = np.clip(1.0 - np.sqrt(x * x + y * y + z * z), 0.0, None)
    values[x > 0.3] *= 0.5
    return (values * 100).astype(dtype)


@pytest.fixture
def sphere():
    return ball()
