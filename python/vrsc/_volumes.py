"""Checks and conversions of what Python hands in as volumes and transfer functions, before
the native side sees them."""

import json
import math
import os

import numpy as np

# Types the native side reads in place (native byte order); others are converted first.
_IN_PLACE = {np.dtype(t) for t in ("u1", "i1", "u2", "i2", "u4", "i4", "f4", "f8")}


def volume_array(array):
    """``array`` as a 3D numpy array of a type vrsc reads: the same array (no copy) when it
    already is one; booleans become ``uint8``, 64-bit integers and half floats ``float32``,
    byte-swapped data native."""
    a = np.asarray(array)
    if a.ndim != 3:
        raise ValueError(f"a volume must be a 3D array, got shape {a.shape} ({a.ndim} dimensions)")
    if a.dtype in _IN_PLACE:
        return a
    if a.dtype.kind == "b":
        return a.astype(np.uint8)
    if a.dtype.kind in "iuf":
        native = a.dtype.newbyteorder("=")
        if native in _IN_PLACE:
            return a.astype(native)
        return a.astype(np.float32)
    raise ValueError(f"a volume's samples must be numbers (integers or floats), not {a.dtype}")


def affine_of(spacing, affine):
    """The 4 x 4 voxel-to-patient (RAS millimetres) matrix, as nested lists of rows."""
    if affine is not None:
        if spacing is not None:
            raise ValueError("give a volume's spacing or its affine, not both (the affine holds the spacing)")
        m = np.asarray(affine, dtype=np.float64)
        if m.shape != (4, 4):
            raise ValueError(f"an affine must be a 4 x 4 matrix, got shape {m.shape}")
        return m.tolist()
    spacing = (1.0, 1.0, 1.0) if spacing is None else spacing
    s = np.asarray(spacing, dtype=np.float64)
    if s.shape != (3,):
        raise ValueError(f"spacing must be three numbers (x, y, z in millimetres), got {spacing!r}")
    if not all(math.isfinite(v) and v > 0 for v in s):
        raise ValueError(f"spacing must be three positive finite numbers, got {tuple(s.tolist())}")
    return np.diag([s[0], s[1], s[2], 1.0]).tolist()


def tf_file(points, path):
    """Writes transfer-function ``points`` as a ParaView colormap at ``path``: rows of
    ``(x, r, g, b, a)``, or ``(x, a)`` for grey rising with opacity; ``x`` in data units,
    colours and opacities in 0..1."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 5) or p.shape[0] < 2:
        raise ValueError(
            f"a transfer function's points must be rows of (x, r, g, b, a) or (x, a), at least two, got shape {p.shape}"
        )
    if not np.isfinite(p).all():
        raise ValueError("a transfer function's points must be finite numbers")
    if p.shape[1] == 2:
        p = np.column_stack([p[:, 0], p[:, 1], p[:, 1], p[:, 1], p[:, 1]])
    if np.any(np.diff(p[:, 0]) < 0):
        raise ValueError("a transfer function's points must be in increasing order of x")
    if np.any((p[:, 1:] < 0) | (p[:, 1:] > 1)):
        raise ValueError("a transfer function's colours and opacities must lie in 0 to 1")
    rgb = [v for row in p for v in (row[0], row[1], row[2], row[3])]
    opacity = [v for row in p for v in (row[0], row[4], 0.5, 0.0)]
    with open(path, "w", encoding="utf-8") as f:
        json.dump([{"Name": os.path.basename(path), "RGBPoints": rgb, "Points": opacity}], f)
