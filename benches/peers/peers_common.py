"""What every contender of the peer benchmark agrees on: the prepared volume, the camera and the
worker protocol (one JSON object per line on standard input, one answer per line on standard
output)."""

import json
import math
import sys

import numpy as np


def load_prepared(case):
    """The volume (float32, shape (z, y, x)) and the transfer function ((1024, 4) floats in
    [0, 1]) that vrsc's `peer_worker prepare` wrote: the samples normalized by the window and
    rounded to half floats as vrsc's texture holds them, the table as vrsc uploads it (half floats,
    entry i standing for the value (i + 0.5) / 1024 of the window)."""
    nx, ny, nz = case["dims"]
    volume = np.fromfile(f"{case['dir']}/volume.f32", dtype="<f4").reshape(nz, ny, nx)
    tf = np.fromfile(f"{case['dir']}/tf.f32", dtype="<f4").reshape(-1, 4)
    return volume, tf


def world_box(case):
    """The volume's box in world units, as vrsc's orbit camera sees it: centred at the origin,
    its largest side 1. Returns (scale per axis, voxel spacing, centre of voxel (0, 0, 0))."""
    extent = np.array(case["extent"], dtype=np.float64)
    scale = extent / extent.max()
    dims = np.array(case["dims"], dtype=np.float64)
    spacing = scale / dims
    origin = -scale / 2 + spacing / 2
    return scale, spacing, origin


def eye_position(camera):
    """vrsc's `OrbitCamera`: azimuth around +z, elevation above the xy plane, looking at the
    centre, +z up."""
    az = math.radians(camera["azimuth"])
    el = math.radians(camera["elevation"])
    d = camera["distance"]
    return (d * math.sin(az) * math.cos(el), d * math.cos(az) * math.cos(el), d * math.sin(el))


def serve(handlers):
    """Answers requests from the driver until standard input ends."""
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            answer = handlers[request["cmd"]](request)
        except Exception as error:  # the driver reports it and goes on without this contender
            answer = {"error": f"{type(error).__name__}: {error}"}
        sys.stdout.write(json.dumps(answer) + "\n")
        sys.stdout.flush()
