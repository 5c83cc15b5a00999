"""vrsc from Python: VRS pipeline functions checked and composed, volumes rendered from numpy
arrays or files into numpy arrays.

>>> import numpy as np, vrsc
>>> z, y, x = np.mgrid[-1:1:64j, -1:1:64j, -1:1:64j]
>>> scene = vrsc.Scene.from_array((x*x + y*y + z*z < 0.5).astype(np.float32))
>>> scene.render(size=(64, 64)).shape
(64, 64, 4)
"""

import os

from ._errors import CompileError, SceneError, UniformTypeError, UnknownNameError, VrscError
from ._scene import Scene
from ._vrsc import Diagnostic, adapter, encode_png
from ._vrsc import check_files as _check_files
from ._vrsc import check_source as _check_source
from ._vrsc import compose as _compose

__all__ = [
    "CompileError",
    "Diagnostic",
    "Scene",
    "SceneError",
    "UniformTypeError",
    "UnknownNameError",
    "VrscError",
    "adapter",
    "check",
    "compose",
    "encode_png",
]


def _is_path(source):
    """Whether ``source`` names a file rather than holding VRS text."""
    if isinstance(source, os.PathLike):
        return True
    return isinstance(source, str) and "\n" not in source and source.strip().endswith(".vrs")


def check(source_or_path, *more_paths):
    """Checks VRS modules, as ``vrsc check`` does: source text, or paths of ``.vrs`` files
    (with their imports). Returns the warnings; raises :class:`vrsc.CompileError` (whose text
    names each error's line, and whose ``diagnostics`` hold them all) when there are errors."""
    if _is_path(source_or_path) or more_paths:
        paths = [os.fspath(p) for p in (source_or_path, *more_paths)]
        return _check_files(paths)
    if not isinstance(source_or_path, str):
        raise TypeError(f"check() takes VRS source text or paths, not {type(source_or_path).__name__}")
    return _check_source(source_or_path, "<string>", os.getcwd())


def compose(scene, view=None):
    """Composes every view of a scene (a :class:`vrsc.Scene` or the path of a scene file), as
    ``vrsc build`` does without writing anything. Returns the warnings; raises
    :class:`vrsc.CompileError` on errors."""
    if isinstance(scene, Scene):
        if scene._file is None:
            scene._ensure()
        return _compose(scene.path, view)
    return _compose(os.fspath(scene), view)
