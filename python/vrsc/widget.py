"""An interactive view of a scene in Jupyter: drag to orbit, wheel to zoom. While the pointer
moves it shows quick previews at a fraction of the size; when it stops it renders the full
picture. Needs ``anywidget`` (``pip install 'vrsc[widget]'``); the rest of vrsc does not.

>>> from vrsc.widget import Viewer
>>> Viewer(scene)            # in a notebook cell
"""

import base64

from ._orbit import Orbit

try:
    import anywidget
    import traitlets
except ImportError as missing:  # vrsc works without Jupyter; only this module needs it
    raise ImportError("vrsc.widget needs anywidget: pip install anywidget (or 'vrsc[widget]')") from missing


_ESM = """
function render({ model, el }) {
  const img = document.createElement("img");
  img.style.width = model.get("width") + "px";
  img.style.height = model.get("height") + "px";
  img.style.imageRendering = "pixelated";
  img.draggable = false;
  const show = () => { img.src = "data:image/png;base64," + model.get("png"); };
  show();
  model.on("change:png", show);
  let last = null, pending = 0;
  const send = (msg) => model.send(msg);
  img.addEventListener("pointerdown", (e) => { last = [e.clientX, e.clientY]; img.setPointerCapture(e.pointerId); });
  img.addEventListener("pointermove", (e) => {
    if (!last) return;
    const dx = e.clientX - last[0], dy = e.clientY - last[1];
    last = [e.clientX, e.clientY];
    if (dx || dy) send({ kind: "drag", dx, dy });
  });
  const end = () => { if (last) { last = null; send({ kind: "end" }); } };
  img.addEventListener("pointerup", end);
  img.addEventListener("pointercancel", end);
  img.addEventListener("wheel", (e) => {
    e.preventDefault();
    send({ kind: "zoom", steps: Math.sign(e.deltaY) });
    clearTimeout(pending);
    pending = setTimeout(() => send({ kind: "end" }), 250);
  });
  el.appendChild(img);
}
export default { render };
"""


class Viewer(anywidget.AnyWidget):
    """A view of ``scene`` that orbits with the mouse and refines when the mouse stops."""

    _esm = _ESM
    png = traitlets.Unicode("").tag(sync=True)
    width = traitlets.Int(384).tag(sync=True)
    height = traitlets.Int(384).tag(sync=True)

    def __init__(self, scene, view=None, size=(384, 384), **kwargs):
        super().__init__(width=size[0], height=size[1], **kwargs)
        self.orbit = Orbit(scene, view, size)
        self._show(moving=False)
        self.on_msg(self._on_message)

    def _show(self, moving):
        self.png = base64.b64encode(self.orbit.picture(moving)).decode("ascii")

    def _on_message(self, _widget, message, _buffers):
        kind = message.get("kind")
        if kind == "drag":
            self.orbit.drag(float(message.get("dx", 0)), float(message.get("dy", 0)))
            self._show(moving=True)
        elif kind == "zoom":
            self.orbit.zoom(float(message.get("steps", 0)))
            self._show(moving=True)
        elif kind == "end":
            self._show(moving=False)
