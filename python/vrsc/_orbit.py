"""The interaction of vrsc.widget.Viewer without Jupyter: a pointer's drags and wheel steps
made into camera moves, previews while it moves and the full picture when it stops."""

from ._vrsc import encode_png


class Orbit:
    """What a pointer does to a view's camera and picture size (no Jupyter here: tested alone).

    ``preview`` divides the size while the pointer moves; ``degrees_per_pixel`` turns a drag
    into azimuth and elevation; a wheel step scales the distance by ``zoom_step``."""

    def __init__(self, scene, view=None, size=(384, 384), preview=4, degrees_per_pixel=0.5, zoom_step=1.1):
        self.scene, self.view, self.size = scene, view, tuple(size)
        self.preview, self.degrees_per_pixel, self.zoom_step = preview, degrees_per_pixel, zoom_step

    def drag(self, dx, dy):
        camera = self.scene.camera(self.view)
        self.scene.set_camera(
            self.view,
            azimuth=(camera["azimuth"] - dx * self.degrees_per_pixel) % 360.0,
            elevation=max(-89.0, min(89.0, camera["elevation"] + dy * self.degrees_per_pixel)),
        )

    def zoom(self, steps):
        camera = self.scene.camera(self.view)
        self.scene.set_camera(self.view, distance=max(0.2, min(20.0, camera["distance"] * self.zoom_step**steps)))

    def picture(self, moving):
        """The PNG of the view: a preview while ``moving``, else the full size."""
        w, h = self.size
        size = (max(1, w // self.preview), max(1, h // self.preview)) if moving else (w, h)
        return encode_png(self.scene.render(self.view, size))
