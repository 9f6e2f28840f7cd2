"""hfrt: compile HyperFun FRep models and evaluate or ray trace them from Python.

    import numpy as np, hfrt
    m = hfrt.Model("my_model(x[3], a[1]) { my_model = 1 - x[1]^2 - x[2]^2 - x[3]^2; }")
    f = m.eval(np.zeros((10, 3)))              # F at 10 points -> ndarray[10]
    img = hfrt.render(m, size=(256, 256))     # ndarray[256, 256, 4] (linear RGB + alpha)

Points are (n, k) arrays (k = the model's x size) of float64 or float32; results have the
input's precision. Contiguous float64/float32 arrays are read in place (no copy); the GIL is
released while hfrt evaluates or renders, so threads evaluate one model in parallel.
"""

import os as _os
import pathlib as _pathlib

from . import _hfrt

__all__ = ["Model", "LIMITS", "CompileError", "Diagnostic", "render", "write_image", "__version__"]
__version__ = "0.1.0"


class Diagnostic:
    """One located compile diagnostic (severity 'error', 'warning' or 'note')."""

    __slots__ = ("severity", "file", "line", "column", "length", "message", "hint")

    def __init__(self, severity, file, line, column, length, message, hint):
        self.severity, self.file, self.line, self.column = severity, file, line, column
        self.length, self.message, self.hint = length, message, hint

    def __str__(self):
        loc = f"{self.file}:{self.line}:{self.column}" if self.line else self.file
        return f"{loc}: {self.severity}: {self.message}"

    __repr__ = __str__


def _diag(d):
    return Diagnostic(d["severity"], d["file"], d["line"], d["column"], d["length"],
                      d["message"], d["hint"])


class CompileError(Exception):
    """The source has errors. str(e) is the rendered text (`file:line:col: error: ...`, the
    source line, a caret, a hint); e.diagnostics the located Diagnostic list."""

    def __init__(self, rendered, diagnostics=()):
        super().__init__(rendered)
        self.diagnostics = [d if isinstance(d, Diagnostic) else _diag(d) for d in diagnostics]
        errors = [d for d in self.diagnostics if d.severity == "error"]
        first = errors[0] if errors else None
        self.file = first.file if first else None
        self.line = first.line if first else 0
        self.column = first.column if first else 0


_hfrt._set_compile_error(CompileError)


def _looks_like_path(text):
    if _os.path.exists(text):
        return True
    return "\n" not in text and "{" not in text and text.strip().lower().endswith(".hf")


#: The names of the limits on hostile input that Model() takes as keyword arguments
#: (docs/limits.md; hfrt::ModelLimits).
LIMITS = ("max_loop_iterations", "max_array_size", "max_slots", "max_model_size",
          "max_source_bytes", "max_mesh_bytes", "max_mesh_triangles", "max_exact_curves")


class Model:
    """A compiled HyperFun object.

    Model(path_or_source, object=None, params=None, *, backend="jit", precision="f64",
          name="<input>", **limits)

    `path_or_source` is a file (a path-like, or a string naming an existing file or ending
    in .hf) or HyperFun source text. Raises CompileError (with located diagnostics) on source
    errors, FileNotFoundError when the file cannot be read, ValueError on bad arguments.
    `limits` are the limits on hostile input (docs/limits.md), by name: max_loop_iterations,
    max_array_size, max_slots, max_model_size, max_source_bytes, max_mesh_bytes,
    max_mesh_triangles, max_exact_curves (positive integers), e.g.
    Model(src, max_loop_iterations=1000). (max_exact_curves is no error: a Bézier patch set
    with more open border curves gets a tessellated field instead of the exact one.)
    Evaluation is thread-safe; set_params may run concurrently (it waits for evaluations).
    """

    def __init__(self, path_or_source, object=None, params=None, *, backend="jit",
                 precision="f64", name="<input>", **limits):
        if isinstance(path_or_source, _os.PathLike):
            text, is_file = _os.fspath(path_or_source), True
        elif isinstance(path_or_source, str):
            text = path_or_source
            is_file = _looks_like_path(text)
        else:
            raise TypeError("Model() expects a path or HyperFun source text")
        params = [] if params is None else [float(v) for v in params]
        for key, value in limits.items():
            if key not in LIMITS:
                raise TypeError(f"Model() got an unexpected keyword argument '{key}' (the limits "
                                f"are {', '.join(LIMITS)})")
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError(f"{key} must be an int (got {value!r})")
            if value < 1:
                raise ValueError(f"{key} must be at least 1 (got {value})")
        self._m = _hfrt._compile(text, is_file, name, object or "", params, backend, precision,
                                 {k: int(v) for k, v in limits.items()})

    # -- shape ---------------------------------------------------------------------------
    @property
    def num_inputs(self):
        """The size of x (coordinates per point)."""
        return self._m.num_inputs

    @property
    def num_params(self):
        """The size of a (parameters)."""
        return self._m.num_params

    @property
    def num_attributes(self):
        """The size of s (attributes; 0 without s)."""
        return self._m.num_attributes

    @property
    def object(self):
        """The evaluated object's name."""
        return self._m.object_name

    @property
    def objects(self):
        """Every object in the source."""
        return list(self._m.object_names)

    @property
    def params(self):
        """The current a[] values (a list)."""
        p = list(self._m.params)
        return p + [0.0] * (self.num_params - len(p))

    @property
    def diagnostics(self):
        """The warnings of the compile (Diagnostic list)."""
        return [_diag(d) for d in self._m.diagnostics]

    # -- evaluation ----------------------------------------------------------------------
    def eval(self, points, attributes=False, out=None):
        """F at points[n, k] -> ndarray[n] (a float for a single point of shape (k,)).
        With attributes=True: (f[n], s[n, num_attributes]). NaN where F has no value.
        out: an ndarray[n] of the points' dtype to write F into (returned), as NumPy's out=:
        no allocation, for callers that evaluate many batches."""
        return self._m.eval(points, attributes, out)

    def eval_interval(self, lo, hi):
        """Encloses F over the boxes [lo[i], hi[i]] (lo, hi: (n, k), lo <= hi) ->
        (f_lo[n], f_hi[n], maybe_nan[n]): every value F takes in box i is in
        [f_lo[i], f_hi[i]] or is NaN (then maybe_nan[i] is True)."""
        return self._m.eval_interval(lo, hi)

    def gradient(self, points):
        """F and its gradient at points[n, k] -> ndarray[n, 4]: columns F, dF/dx1, dF/dx2,
        dF/dx3 (automatic differentiation)."""
        return self._m.gradient(points)

    def set_params(self, params):
        """Sets a[1..] (missing ones are 0) without recompiling."""
        self._m.set_params([float(v) for v in params])

    def set_time(self, time):
        """Sets x[4] (time) for renders, where points have three coordinates; eval takes every
        input from its points. A number, never a recompile."""
        self._m.set_time(float(time))

    @property
    def time(self):
        """The time set by set_time (x[4] of renders; default 0)."""
        return self._m.time

    def render(self, size=(512, 512), camera=None, **kwargs):
        """hfrt.render(self, size, camera, **kwargs)."""
        return render(self, size, camera, **kwargs)

    def __repr__(self):
        return (f"hfrt.Model(object={self.object!r}, x[{self.num_inputs}], "
                f"a[{self.num_params}], s[{self.num_attributes}])")


def render(model_or_scene, size=(512, 512), camera=None, *, bbox=None, root="auto", spp=1,
           threads=0, shadows=True, background=None):
    """Ray traces a model -> ndarray[h, w, 4] float32 (linear RGB and alpha coverage, row 0 at
    the top), as `hfrt render` does.

    model_or_scene: a Model, or a path to a .hf model file. size: (width, height) or one int.
    camera: dict with any of eye, look_at, up (3 values each), fov (degrees), ortho (view
    width); what is missing is framed automatically. bbox: 6 values (or one half-size).
    root: 'auto', 'sign', 'interval' or 'analytic'.

    A scene file (.toml, docs/scenes.md) is traced with its own camera, lights, materials and
    settings at `size` on `threads`; the other arguments must be left at their defaults. A bad
    scene or a model that does not compile raises CompileError with the located message.
    """
    if isinstance(model_or_scene, Model):
        model = model_or_scene
    elif isinstance(model_or_scene, (str, _os.PathLike)):
        path = _os.fspath(model_or_scene)
        if path.lower().endswith(".toml"):
            if camera is not None or bbox is not None or root != "auto" or spp != 1 or \
                    not shadows or background is not None:
                raise ValueError("hfrt.render: a scene file sets camera, bbox, root, spp, "
                                 "shadows and background itself (pass size and threads only)")
            width, height = (size, size) if isinstance(size, int) else (int(v) for v in size)
            return _hfrt._render_scene(path, width, height, int(threads))
        model = Model(_pathlib.Path(path))
    else:
        raise TypeError("render() expects a Model or a path")
    if isinstance(bbox, (int, float)):
        bbox = [bbox]
    if isinstance(size, int):
        width = height = size
    else:
        width, height = (int(v) for v in size)
    return model._m.render(width, height, dict(camera or {}), bbox, root, int(spp),
                           int(threads), bool(shadows), background)


def write_image(path, rgba):
    """Writes an (h, w, 4) render to an image file; the format follows the extension (PNG,
    EXR, TIFF, JPEG), as `hfrt render -o` writes it."""
    _hfrt.write_image(_os.fspath(path), rgba)
