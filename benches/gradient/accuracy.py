"""The accuracy of a four-tap shading gradient (issue 37, item 5): tetrahedral differences (the
taps at four corners of a cube, one voxel out along each axis) against the six-tap central
differences of `std::gradient`, both read through trilinear interpolation as the shader reads
them. Measured, not used: the tetrahedral stencil's error is first order in the mixed second
derivatives, about 13 degrees (median) on an edge as sharp as the phantoms', where central
differences are within 1.4; and on lavapipe its four diagonal taps were no faster than the six
axial ones (benches/peers, `mni_t1_ramp`, shaded 512^2: 392 against 362 ms).

Two volumes: the MNI152 T1 (../shared/data, skipped when absent) and an analytic ball whose
true gradient is known (radius 20 voxels, a Gaussian-blurred edge of sigma 0.8 voxel, as the
built-in phantoms have). Positions are random; those where the gradient is small (no surface)
are left out. Prints the angle between the stencils' normals and, for the ball, each one's
angle to the true normal (degrees: median, 95th percentile, largest).

    python/.venv/bin/python benches/gradient/accuracy.py
"""

import math
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
MNI_T1 = ROOT / "../shared/data/mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz"
TETRAHEDRON = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=np.float64)


def trilinear(volume, p):
    """`volume` (x, y, z) at voxel coordinates `p` (N x 3), clamped to the edge as a sampler."""
    hi = np.array(volume.shape) - 1
    p = np.clip(p, 0, hi)
    i = np.minimum(np.floor(p).astype(int), hi - 1)
    f = p - i
    out = np.zeros(len(p))
    for corner in np.ndindex(2, 2, 2):
        c = np.array(corner)
        w = np.prod(np.where(c == 1, f, 1 - f), axis=1)
        j = i + c
        out += w * volume[j[:, 0], j[:, 1], j[:, 2]]
    return out


def central(volume, p):
    axes = np.eye(3)
    return np.stack([(trilinear(volume, p + a) - trilinear(volume, p - a)) / 2 for a in axes], axis=1)


def tetrahedral(volume, p):
    taps = [trilinear(volume, p + c) for c in TETRAHEDRON]
    return sum(f[:, None] * c for f, c in zip(taps, TETRAHEDRON)) / 4


def angles(a, b):
    """The angle between each pair (degrees); a stencil that gives no gradient counts as 90."""
    norms = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    cos = np.divide(np.sum(a * b, axis=1), norms, out=np.zeros(len(a)), where=norms > 0)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def summary(label, deg):
    print(f"  {label}: median {np.median(deg):.2f}, 95th percentile {np.percentile(deg, 95):.2f}, largest {deg.max():.2f}")


def surface_points(volume, count, rng, minimum):
    """Random positions whose central-difference gradient is at least `minimum` of the largest."""
    p = rng.uniform(2, np.array(volume.shape) - 3, size=(count, 3))
    g = central(volume, p)
    mag = np.linalg.norm(g, axis=1)
    keep = mag >= minimum * mag.max()
    return p[keep], g[keep]


def ball(n=64, radius=20.0, sigma=0.8):
    x = np.arange(n) - (n - 1) / 2
    r = np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)
    erfc = np.vectorize(math.erfc)
    return 0.5 * erfc((r - radius) / (sigma * math.sqrt(2))), (n - 1) / 2


def main():
    rng = np.random.default_rng(7)
    volume, centre = ball()
    p, g = surface_points(volume, 200_000, rng, 0.2)
    truth = -(p - centre)  # the ball's values fall outwards
    t = tetrahedral(volume, p)
    print(f"ball (radius 20 voxels, edge sigma 0.8 voxel), {len(p)} surface positions:")
    summary("central to true normal", angles(g, truth))
    summary("tetrahedral to true normal", angles(t, truth))
    summary("tetrahedral to central", angles(t, g))
    print(f"  magnitude, tetrahedral over central: median {np.median(np.linalg.norm(t, axis=1) / np.linalg.norm(g, axis=1)):.3f}")
    if not MNI_T1.exists():
        print(f"MNI152 T1 absent ({MNI_T1}): skipped")
        return
    import nibabel

    t1 = np.asarray(nibabel.load(str(MNI_T1)).dataobj, dtype=np.float64)
    p, g = surface_points(t1, 400_000, rng, 0.1)
    t = tetrahedral(t1, p)
    print(f"MNI152 T1, {len(p)} positions with a gradient of at least a tenth of the largest:")
    summary("tetrahedral to central", angles(t, g))
    print(f"  magnitude, tetrahedral over central: median {np.median(np.linalg.norm(t, axis=1) / np.linalg.norm(g, axis=1)):.3f}")


if __name__ == "__main__":
    main()
