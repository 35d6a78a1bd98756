"""Penumbra, a physically based CPU path tracer, from Python.

Load a scene, render it into a numpy array, change a parameter, render again::

    import penumbra
    scene = penumbra.load_file("scenes/cornell-box.xml")
    image = penumbra.render(scene, spp=64)          # (height, width, 3) float32
    scene.set("red.reflectance", [0.2, 0.8, 0.2])   # by object id; geometry is kept
    penumbra.write("green.exr", penumbra.render(scene, spp=64))

Scenes are Mitsuba 3 XML (``load_file``, ``load_string``) or Mitsuba's
dictionary form (``load_dict``). ``render`` gives the command line's image bit
for bit for the same settings (``penumbra render scene.xml --spp N --seed S``).
"""

from ._penumbra import Error, Scene, __version__
from ._penumbra import load_file as _load_file
from ._penumbra import load_string as _load_string
from ._penumbra import read as _read
from ._penumbra import render as _render
from ._penumbra import write as _write
from ._dict import load_dict
from ._progress import progress_bar

__all__ = [
    "Error",
    "Scene",
    "load_file",
    "load_string",
    "load_dict",
    "render",
    "read",
    "write",
    "__version__",
]


def load_file(path, **params):
    """Loads a Mitsuba 3 XML scene; ``params`` are its ``-D name=value``
    definitions (``load_file("scene.xml", spp=16)`` fills ``$spp``)."""
    return _load_file(str(path), params)


def load_string(xml, base_dir=None, **params):
    """Loads a scene from Mitsuba 3 XML text; relative file names resolve from
    ``base_dir`` (default: the working directory)."""
    return _load_string(xml, params, None if base_dir is None else str(base_dir))


def render(
    scene, spp=None, seed=0, threads=None, integrator=None, aovs=(), progress=True, checkpoint=None, display_server=None
):
    """Renders ``scene`` and returns its image as a float32 array of shape
    (height, width, 3), linear RGB.

    - ``spp``: samples per pixel (default: the scene's sampler's).
    - ``seed``: the sampler's seed (as ``--seed``).
    - ``threads``: worker threads (default: all cores).
    - ``integrator``: ``"path"``, ``"direct:emitter_samples=4"``, ... (as ``--integrator``).
    - ``aovs``: extra layers (``"albedo"``, ``"normal"``, ``"depth"``,
      ``"position"``, ``"variance"``): then a dict ``{"image": ..., "albedo": ...}``
      is returned, each (height, width, channels). Integrators with output
      channels of their own (``aov``, ``moment``) also return such a dict, with
      one array per layer as the command line's EXR names them (``"dd.y"``, ...).
    - ``progress``: ``True`` for a progress bar (tqdm if installed), ``False`` for
      none, or a callable ``f(done, total)``.
    - ``checkpoint``: a file to resume from (if it belongs to this render); it is
      written when the render is interrupted (Ctrl-C) and deleted once it completes.
    - ``display_server``: ``"HOST:PORT"`` of a running tev (default port 14158):
      the image is streamed to it after every pass (as ``--display-server``).

    The GIL is released while rendering; Ctrl-C stops the render and raises
    KeyboardInterrupt once every worker thread has stopped.
    """
    if isinstance(aovs, str):
        aovs = [a for a in aovs.split(",") if a]
    bar = None
    if progress is True:
        bar = progress_bar()
        callback = bar.update
    elif callable(progress):
        callback = progress
    elif progress in (False, None):
        callback = None
    else:
        raise TypeError("progress must be True, False or a callable f(done, total)")
    try:
        out = _render(
            scene,
            spp=spp,
            seed=seed,
            threads=threads,
            integrator=integrator,
            aovs=list(aovs),
            progress=callback,
            checkpoint=None if checkpoint is None else str(checkpoint),
            display_server=display_server,
        )
    finally:
        if bar is not None:
            bar.close()
    return out if aovs or len(out) > 1 else out["image"]


def read(path, metadata=False):
    """Reads an EXR, PNG, JPEG or HDR file as a float32 (height, width, 3) array
    of linear RGB. With ``metadata=True`` returns a dict: ``image``, EXR layers by
    name (``albedo``: (height, width, 3), ...) and ``metadata`` (the
    ``penumbra:*`` attributes)."""
    out = _read(str(path))
    return out if metadata else out["image"]


def write(path, image, layers=None, metadata=None):
    """Writes a (height, width, 3) array of linear RGB to an EXR, PNG, PFM or HDR
    file by extension (PNG: sRGB, 8-bit, clamped). For EXR, ``layers``
    (``{"albedo": array, ...}``) and ``metadata`` (``{key: text}``, stored as
    ``penumbra:key``) go with it. A dict returned by ``render`` with AOVs may be
    passed as ``image``."""
    import numpy as np

    if isinstance(image, dict):
        layers = dict(layers or {}, **{k: v for k, v in image.items() if k != "image"})
        image = image["image"]
    image = np.ascontiguousarray(image, dtype=np.float32)
    if image.ndim == 2:
        image = np.repeat(image[:, :, None], 3, axis=2)
    items = []
    for name, a in (layers or {}).items():
        a = np.ascontiguousarray(a, dtype=np.float32)
        if a.ndim == 2:
            a = a[:, :, None]
        items.append((name, a))
    _write(str(path), image, items, metadata)
