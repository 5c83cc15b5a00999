"""The notebook viewer's interaction (orbit, zoom, preview then full picture), and the widget
itself where anywidget is installed."""

import numpy as np
import pytest

import vrsc
from vrsc._orbit import Orbit


def test_dragging_orbits_and_previews_then_refines(sphere):
    scene = vrsc.Scene.from_array(sphere)
    orbit = Orbit(scene, size=(64, 48), preview=4)
    start = scene.camera()
    orbit.drag(20, -10)
    moved = scene.camera()
    assert moved["azimuth"] == pytest.approx((start["azimuth"] - 10.0) % 360.0)
    assert moved["elevation"] == pytest.approx(start["elevation"] - 5.0)
    orbit.zoom(2)
    assert scene.camera()["distance"] == pytest.approx(start["distance"] * 1.21, rel=1e-5)
    orbit.drag(0, 10_000)
    assert scene.camera()["elevation"] == 89.0
    preview, full = orbit.picture(moving=True), orbit.picture(moving=False)
    assert preview[:8] == full[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(preview) < len(full)
    assert scene.render(size=(16, 12)).shape == (12, 16, 4)


def test_the_widget_shows_the_scene(sphere):
    widget = pytest.importorskip("vrsc.widget", exc_type=ImportError)
    viewer = widget.Viewer(vrsc.Scene.from_array(sphere), size=(32, 32))
    first = viewer.png
    viewer._on_message(viewer, {"kind": "drag", "dx": 40, "dy": 0}, [])
    assert viewer.png != first
    viewer._on_message(viewer, {"kind": "end"}, [])
    assert viewer.png and np.frombuffer(viewer.png.encode(), dtype=np.uint8).size > 0
