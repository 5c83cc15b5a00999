"""The exceptions vrsc raises. The native module raises these classes (they are defined here so
that an unknown name can be both a ``vrsc.SceneError`` and a ``KeyError``)."""


class VrscError(Exception):
    """Every error of vrsc."""


class CompileError(VrscError):
    """Modules or a scene with errors. ``diagnostics`` holds every diagnostic (errors and
    warnings) as :class:`vrsc.Diagnostic` objects; ``str()`` names each error's file and line,
    then shows them as ``vrsc check`` prints them."""

    def __init__(self, message, diagnostics=()):
        super().__init__(message)
        self.diagnostics = list(diagnostics)

    @property
    def errors(self):
        return [d for d in self.diagnostics if d.is_error]


class SceneError(VrscError):
    """A scene that cannot be rendered as asked: a volume or transfer function that does not
    load, a GPU that refuses the work, a request that does not fit the scene."""


class UnknownNameError(SceneError, KeyError):
    """A view, uniform or state field the scene does not have (a ``KeyError`` too)."""

    def __str__(self):
        # KeyError shows its argument's repr; the message reads better as it is.
        return str(self.args[0]) if self.args else ""


class UniformTypeError(SceneError, TypeError):
    """A uniform value of the wrong type or length (a ``TypeError`` too)."""
