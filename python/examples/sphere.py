"""The README's example: a numpy sphere, a VRS module that tints it, the picture written as a
PNG (and shown, in a notebook). Runs headless: `python python/examples/sphere.py [OUT.png]`."""

import sys

import numpy as np

import vrsc

# A 96^3 ball, bright at its centre and fading to its surface: array[i, j, k] is voxel (i, j, k).
z, y, x = np.mgrid[-1:1:96j, -1:1:96j, -1:1:96j]
ball = np.clip(1.0 - np.sqrt(x * x + y * y + z * z), 0.0, None).astype(np.float32)

# A pipeline function placed after the standard classification: every sample's colour is
# multiplied by a uniform that Python can set.
TINT = """
/// Tints every classified sample.
pipeline tint after classification.primary {
    /// The colour the ball takes.
    uniform tint: vec3f = vec3f(1.0, 0.55, 0.2) in 0.0 .. 1.0;
    state color: vec4f;
    state.color = vec4f(state.color.rgb * tint, state.color.a);
}
"""

vrsc.check(TINT)  # raises vrsc.CompileError naming the line of any mistake
# Transfer function: rows of (value, r, g, b, opacity); transparent outside, opaque inside.
tf = [[0.0, 1.0, 1.0, 1.0, 0.0], [0.15, 1.0, 1.0, 1.0, 0.0], [0.3, 1.0, 1.0, 1.0, 0.9], [1.0, 1.0, 1.0, 1.0, 1.0]]
scene = vrsc.Scene.from_array(ball, spacing=(1.0, 1.0, 1.0), tf=tf, modules=[TINT], shading=True)
scene.set_uniform("tint", [1.0, 0.55, 0.2])
image = scene.render(size=(256, 256))  # 256 x 256 x 4 uint8
r, g, b, a = image[128, 128]
print(f"rendered {image.shape} {image.dtype} on {vrsc.adapter()}; centre pixel ({r}, {g}, {b}, {a})")

out = sys.argv[1] if len(sys.argv) > 1 else "sphere.png"
scene.save_png(out, size=(256, 256))
print(f"wrote {out}")
