"""vrsc.Scene: a scene file loaded, or a scene described from Python (volumes from numpy
arrays or files, modules from files or strings, views), rendered into numpy arrays.

A scene described here is written as a scene file (TOML) into a folder of its own and composed
from there, so it passes exactly the checks, and gets exactly the diagnostics, that ``vrsc build``
gives the same scene; array volumes are read from the arrays themselves, never written out."""

import os
import shutil
import tempfile
import weakref

from . import _toml, _volumes
from ._errors import SceneError
from ._vrsc import SceneHandle, encode_png

# Scene keys of a [render] table, a [[view]] table and a camera that the methods below accept;
# the scene parser checks their values.
_VIEW_KEYS = ("size", "camera", "axis", "position", "slab", "convention", "meshes", "overlay", "planes", "render")


class Scene:
    """A scene to render. Make one with :meth:`Scene.load` (a scene file), :meth:`Scene.from_array`
    (one numpy volume and a 3D view), or ``Scene()`` and the ``add_*`` methods."""

    def __init__(self):
        self._file = None
        self._dir = tempfile.mkdtemp(prefix="vrsc-scene-")
        self._cleanup = weakref.finalize(self, shutil.rmtree, self._dir, ignore_errors=True)
        self._render = {}
        self._volumes = []
        self._arrays = {}
        self._modules = []
        self._views = []
        self._initial = {}
        self._set = {}
        self._handle = None
        self._changed = True
        self._arrays_changed = True

    # -- making scenes ------------------------------------------------------------------------

    @classmethod
    def load(cls, path):
        """The scene file at ``path`` (``scene.toml``): composed and its volumes loaded now;
        a scene with errors raises :class:`vrsc.CompileError`."""
        path = os.fspath(path)
        if not os.path.exists(path):
            raise FileNotFoundError(f"cannot read `{path}`: no such file")
        scene = cls()
        scene._cleanup()
        scene._file = os.path.abspath(path)
        scene._dir = os.path.dirname(scene._file)
        scene._ensure()
        return scene

    @classmethod
    def from_array(
        cls,
        array,
        spacing=None,
        *,
        affine=None,
        tf=None,
        compositing=None,
        window=None,
        modules=(),
        size=(256, 256),
        camera=None,
        shading=None,
        name="volume",
    ):
        """A scene of one volume from a 3D numpy array (``array[i, j, k]`` is voxel (i, j, k),
        i along x, as nibabel's arrays), seen by one 3D view named ``3d``.

        ``spacing`` (x, y, z in millimetres, default 1) or ``affine`` (4 x 4, voxel index to RAS
        millimetres) place it; ``tf`` is a preset name, a ParaView JSON file or points (rows of
        ``(x, r, g, b, a)`` in data units); ``compositing`` is ``"dvr"``, ``"mip"``, ``"minip"``,
        ``"average"`` or ``"iso"``; ``modules`` are VRS files or source texts."""
        scene = cls()
        scene.add_volume(name, array, spacing=spacing, affine=affine, tf=tf, window=window)
        settings = {"compositing": compositing, "shading": shading}
        scene.set_render(**{k: v for k, v in settings.items() if v is not None})
        for module in modules:
            scene.add_module(module)
        scene.add_view("3d", size=size, camera=camera)
        scene._ensure()
        return scene

    def _described(self):
        if self._file is not None:
            raise SceneError(f"this scene is the file `{self._file}`: change it by editing the file (then reload())")
        self._changed = True

    def add_volume(
        self, name, data=None, *, path=None, phantom=None, spacing=None, affine=None, tf=None, role=None, window=None,
        **keys
    ):
        """Adds a volume: a numpy array (``data``), a file (``path``: NIfTI, NRRD, MetaImage,
        DICOM folder, Zarr) or a built-in ``phantom``. The first volume is the primary one unless
        ``role`` says otherwise; later ones are ``additional``. Other ``[[volume]]`` keys of the
        scene format pass through ``keys``."""
        self._described()
        if sum(x is not None for x in (data, path, phantom)) != 1:
            raise ValueError("give a volume exactly one of data (an array), path or phantom")
        if any(v["name"] == name for v in self._volumes):
            raise ValueError(f"the scene already has a volume `{name}`")
        table = {"name": name, "role": role or ("primary" if not self._volumes else "additional")}
        if data is not None:
            array = _volumes.volume_array(data)
            self._arrays[name] = (array, _volumes.affine_of(spacing, affine))
            self._arrays_changed = True
            table["path"] = f"{name}.numpy"
        else:
            if spacing is not None or affine is not None:
                raise ValueError("spacing and affine are for arrays: a file has its own")
            if path is not None:
                table["path"] = os.path.abspath(os.fspath(path))
            else:
                table["phantom"] = phantom
        if tf is not None:
            table["tf"] = self._tf(name, tf)
        if window is not None:
            table["window"] = list(window)
        table.update(keys)
        self._volumes.append(table)
        return self

    def _tf(self, volume, tf):
        if isinstance(tf, (str, os.PathLike)):
            tf = os.fspath(tf)
            # A preset is a name; anything else is a file.
            return tf if tf.isidentifier() else os.path.abspath(tf)
        file = os.path.join(self._dir, f"{volume}.tf.json")
        _volumes.tf_file(tf, file)
        return os.path.basename(file)

    def set_volume(self, name, data):
        """Gives array volume ``name`` a new array (same rules as ``add_volume``)."""
        self._described()
        if name not in self._arrays:
            raise KeyError(f"the scene has no array volume `{name}`")
        self._arrays[name] = (_volumes.volume_array(data), self._arrays[name][1])
        self._arrays_changed = True

    def update(self, name=None):
        """Says that array volume ``name`` (every array volume when ``None``) was written in
        place: the next render uploads it again."""
        handle = self._ensure()
        for volume in [name] if name is not None else list(self._arrays):
            handle.touch(volume)
        handle.reload()

    def add_module(self, module, *, instances=None, name=None):
        """Adds a VRS module: a path to a ``.vrs`` file, or source text (written next to the
        scene as ``NAME.vrs``). ``instances`` instantiates a template module."""
        self._described()
        text = os.fspath(module) if isinstance(module, os.PathLike) else module
        if not isinstance(text, str):
            raise TypeError(f"a module is a path or VRS source text, not {type(module).__name__}")
        if "\n" not in text and text.endswith(".vrs") and not text.lstrip().startswith("pipeline"):
            path = os.path.abspath(text)
            if not os.path.exists(path):
                raise FileNotFoundError(f"cannot read `{text}`: no such file")
        else:
            name = name or f"module_{len(self._modules) + 1}"
            path = os.path.join(self._dir, f"{name}.vrs")
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
            path = os.path.basename(path)
        self._modules.append({"path": path, "instances": list(instances) if instances is not None else None})
        return self

    def add_view(self, name, kind="raycast", **keys):
        """Adds a view: ``kind`` is ``"raycast"`` (keys ``size``, ``camera`` as a dict of azimuth,
        elevation, distance, fov) or ``"slice"`` (``axis``, ``position``, ``slab``, ``convention``);
        ``render`` overrides ``[render]`` keys for this view."""
        self._described()
        if any(v["name"] == name for v in self._views):
            raise ValueError(f"the scene already has a view `{name}`")
        unknown = sorted(set(keys) - set(_VIEW_KEYS))
        if unknown:
            raise TypeError(f"add_view() got unknown keys {unknown}; a view takes {', '.join(_VIEW_KEYS)}")
        self._views.append({"name": name, "kind": kind, **{k: v for k, v in keys.items() if v is not None}})
        return self

    def set_render(self, **settings):
        """Sets ``[render]`` keys (``compositing``, ``shading``, ``lights``, ``step_size``, ...)."""
        self._described()
        self._render.update(settings)
        return self

    def set_initial(self, **uniforms):
        """Sets ``[uniforms]`` of the scene: initial values, checked against the declared types
        when the scene composes."""
        self._described()
        self._initial.update(uniforms)
        return self

    def toml(self):
        """The scene file this scene is (written from the description, or read)."""
        if self._file is not None:
            with open(self._file, encoding="utf-8") as f:
                return f.read()
        parts = ["# Written by vrsc.Scene.\n"]
        if self._render:
            parts.append(_toml.table("render", self._render))
        for v in self._volumes:
            parts.append(_toml.table("[volume]", v))
        for m in self._modules:
            parts.append(_toml.table("[module]", m))
        if self._initial:
            parts.append(_toml.table("uniforms", self._initial))
        for v in self._views:
            parts.append(_toml.table("[view]", v))
        return "\n".join(parts)

    def _ensure(self):
        """The native scene, composed and loaded as the description is now."""
        if self._file is not None:
            if self._handle is None:
                self._handle = SceneHandle.open(self._file, [])
            return self._handle
        if not self._changed and self._handle is not None:
            return self._handle
        path = os.path.join(self._dir, "scene.toml")
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.toml())
        if self._handle is None or self._arrays_changed:
            arrays = [(name, array, affine) for name, (array, affine) in self._arrays.items()]
            self._handle = SceneHandle.open(path, arrays)
            self._arrays_changed = False
            for name, value in self._set.items():
                if any(name == u["name"] for u in self._handle.uniforms()):
                    self._handle.set_uniform(name, value)
        else:
            self._handle.reload()
        self._changed = False
        return self._handle

    def reload(self):
        """Reads a loaded scene's file and modules again (a described scene's modules too)."""
        handle = self._ensure()
        handle.reload()

    # -- rendering ---------------------------------------------------------------------------

    def render(self, view=None, size=None, probe=None, *, probe_threshold=None, probe_sample=None, samples=None):
        """Renders ``view`` (the first when ``None``) at ``size`` = (width, height) (the view's
        own when ``None``): an H x W x 4 ``uint8`` array (straight alpha). A path-traced view
        (``compositing = "pathtrace"``) is the mean of ``samples`` frames (16 when ``None``;
        frames already rendered of the same picture count). With ``probe``, the
        values of that state field instead: ``float32``, H x W for a scalar, H x W x N for a
        vector, NaN where a pixel has none (read where the field's lifetime says, or at an
        opacity ``probe_threshold`` or sample ``probe_sample``)."""
        handle = self._ensure()
        size = _size(size)
        if probe is None:
            if probe_threshold is not None or probe_sample is not None:
                raise ValueError("probe_threshold and probe_sample need a probe")
            if samples is not None and (isinstance(samples, bool) or not isinstance(samples, int) or samples < 1):
                raise ValueError(f"samples must be a whole number of at least 1, not {samples!r}")
            return handle.render(view, size, samples)
        values, _legend = handle.probe(probe, view, size, probe_threshold, probe_sample)
        return values

    def probe_legend(self, field, view=None, size=None):
        """What ``render(probe=field)`` shows and how to read it (its value range)."""
        _values, legend = self._ensure().probe(field, view, _size(size), None, None)
        return legend

    def _repr_png_(self):
        """The first view as a PNG (notebooks show a scene as its picture)."""
        return encode_png(self.render())

    def save_png(self, path, view=None, size=None):
        """Renders ``view`` and writes it as a PNG file."""
        with open(path, "wb") as f:
            f.write(encode_png(self.render(view, size)))

    # -- what the scene holds ----------------------------------------------------------------

    @property
    def views(self):
        """The views' names."""
        return self._ensure().views()

    @property
    def diagnostics(self):
        """The warnings of the last composition (errors raise instead)."""
        return self._ensure().warnings()

    @property
    def notices(self):
        """Notes of the renderer: automatic windows, phantoms standing in for missing files."""
        return self._ensure().notices()

    @property
    def uniforms(self):
        """Every uniform of the scene's views, by name: dicts with ``type``, ``value``,
        ``default``, ``range``, ``doc``, ``views`` and ``set_by_renderer``."""
        return {u["name"]: u for u in self._ensure().uniforms()}

    def get_uniform(self, name):
        return self._ensure().get_uniform(name)

    def set_uniform(self, name, value):
        """Sets uniform ``name`` in every view that reads it; the value must fit the declared
        type (``vrsc.UniformTypeError``, a ``TypeError``, otherwise); unknown names raise
        ``vrsc.UnknownNameError`` (a ``KeyError``)."""
        self._ensure().set_uniform(name, value)
        self._set[name] = value

    def __getitem__(self, name):
        return self.get_uniform(name)

    def __setitem__(self, name, value):
        self.set_uniform(name, value)

    def camera(self, view=None):
        """The orbit camera of a raycast view: azimuth, elevation, distance, fov."""
        return self._ensure().camera(view)

    def set_camera(self, view=None, **camera):
        """Moves a raycast view's camera (``azimuth``, ``elevation``, ``distance``, ``fov``)."""
        self._ensure().set_camera(view, **camera)

    @property
    def occlusion_groups(self):
        """The occlusion groups the views draw (``[[group]] kind = "occlusion"``), each with
        the opacity what it hides shows with: a dict in scene order."""
        return dict(self._ensure().occlusion_groups())

    def set_group_opacity(self, name, opacity):
        """Shows what occlusion group ``name`` hides with ``opacity`` (0 to 1) in every view;
        kept when the scene is reloaded."""
        self._ensure().set_group_opacity(name, float(opacity))

    def explain(self, view=None):
        """The composed WGSL of a view, each function annotated with the VRS file and line it
        came from (``vrsc explain``)."""
        return self._ensure().explain(view)

    def pipeline(self, view=None):
        """The renderer tree (``picture: ...``) and pipeline map of a view (``vrsc pipeline``)."""
        return self._ensure().pipeline(view)

    @property
    def path(self):
        """The scene file (the one written for a described scene)."""
        return self._file or os.path.join(self._dir, "scene.toml")

    def __repr__(self):
        what = self._file or "described in Python"
        return f"<vrsc.Scene {what}: volumes {[v['name'] for v in self._volumes] or '(from the file)'}>"


def _size(size):
    if size is None:
        return None
    try:
        w, h = size
    except (TypeError, ValueError):
        raise ValueError(f"size must be (width, height), got {size!r}") from None
    if not all(isinstance(n, int) or hasattr(n, "__index__") for n in (w, h)):
        raise TypeError(f"size must be two integers, got {size!r}")
    w, h = int(w), int(h)
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise ValueError(f"size must be 1 to 16384 pixels each way, got {w} x {h}")
    return (w, h)
