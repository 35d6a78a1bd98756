"""``load_dict``: Mitsuba 3's dictionary form of a scene, written out as
Mitsuba XML (one element per line) and loaded as such, so a dict and the
equivalent XML file give the same image bit for bit. Errors name the
dictionary key where the XML reader names a line.

The form, as Mitsuba's ``load_dict``: ``{"type": "scene", key: object, ...}``;
an object is ``{"type": plugin, param: value, ..., child_key: object}``;
top-level keys become object ids, nested keys the name the object is given
to its parent. Values: bool, int, float, str; ``{"type": "rgb", "value":
[r, g, b]}``; ``{"type": "spectrum", "value": v or [(nm, v), ...]}``;
``{"type": "ref", "id": name}``; a 4x4 matrix (nested lists, a numpy array or
anything with a ``matrix`` attribute, such as ``mi.ScalarTransform4f``) as a
transform; three numbers as a point for position-like names (``center``,
``origin``, ``target``, ``up``, ``direction``, ``position``) and as an RGB
colour otherwise. A ``bitmap`` texture's or an ``envmap``'s ``data`` may be a
numpy image, ``(H, W, 3)`` linear RGB or ``(H, W)`` grey, instead of a
``filename`` (as in Mitsuba); it is passed beside the XML, not written into it.
"""

import math
from xml.sax.saxutils import quoteattr

from ._penumbra import Error, plugins
from ._penumbra import load_string as _load_string

# Keys that say which kind a nested object is, as Mitsuba's own names.
_KIND_OF_KEY = {
    "bsdf": "bsdf",
    "emitter": "emitter",
    "sensor": "sensor",
    "film": "film",
    "sampler": "sampler",
    "rfilter": "rfilter",
    "integrator": "integrator",
}
_POINT_NAMES = {"center", "origin", "target", "up", "direction", "position", "p0", "p1"}


def _path(keys):
    return "dict" + "".join("[%r]" % k for k in keys)


def _kinds():
    table = {}
    for tag, names in plugins():
        for n in names:
            table.setdefault(n, []).append(tag)
    return table


def _number(x, keys):
    x = float(x)
    if not math.isfinite(x):
        raise Error("%s: %r is not a finite number" % (_path(keys), x))
    return repr(x)


def _matrix(v):
    """v as 16 numbers (row-major) if it is a 4x4 matrix, else None."""
    if hasattr(v, "matrix"):
        v = v.matrix
    try:
        import numpy as np

        a = np.asarray(v, dtype=float)
    except Exception:
        return None
    if a.shape == (4, 4):
        return [float(x) for x in a.reshape(-1)]
    return None


def _is_image(v):
    """Whether v is an array of two or three dimensions (an image)."""
    return getattr(v, "ndim", 0) in (2, 3) and not isinstance(v, (str, bytes))


class _Writer:
    def __init__(self):
        self.lines = []
        self.keys = []  # the key path of each line
        self.kinds = _kinds()
        self.images = []  # (object id, "data", array) passed beside the XML
        self.ids = []  # the id of each open object, innermost last

    def emit(self, depth, text, keys):
        self.lines.append("  " * depth + text)
        self.keys.append(list(keys))

    def tag_of(self, plugin, key, keys):
        if key in _KIND_OF_KEY:
            return _KIND_OF_KEY[key]
        tags = self.kinds.get(plugin, [])
        if len(tags) == 1:
            return tags[0]
        if not tags:
            raise Error("%s: plugin type %r is not one Penumbra builds" % (_path(keys), plugin))
        raise Error(
            "%s: plugin type %r is a %s; put it under one of the keys %s"
            % (_path(keys), plugin, " or a ".join(tags), ", ".join(repr(t) for t in tags))
        )

    def obj(self, d, depth, key, keys, top):
        if not isinstance(d.get("type"), str):
            raise Error("%s: an object needs a 'type' (a plugin name)" % _path(keys))
        plugin = d["type"]
        tag = self.tag_of(plugin, key, keys)
        attrs = " type=%s" % quoteattr(plugin)
        ident = d.get("id", key if top else None)
        if ident is None and _is_image(d.get("data")):
            # An id to address the array by (ids of nested objects are allowed).
            ident = "__data_%d" % len(self.images)
        if ident is not None:
            attrs += " id=%s" % quoteattr(str(ident))
        if not top and key is not None:
            attrs += " name=%s" % quoteattr(str(key))
        self.emit(depth, "<%s%s>" % (tag, attrs), keys)
        self.ids.append(None if ident is None else str(ident))
        self.members(d, depth + 1, keys, top=False)
        self.ids.pop()
        self.emit(depth, "</%s>" % tag, keys)

    def members(self, d, depth, keys, top):
        for k, v in d.items():
            if k in ("type", "id"):
                continue
            if not isinstance(k, str):
                raise Error("%s: keys are strings, not %r" % (_path(keys), k))
            self.value(k, v, depth, keys + [k], top)

    def value(self, k, v, depth, keys, top):
        name = quoteattr(k)
        if isinstance(v, dict):
            t = v.get("type")
            if t == "rgb":
                val = v.get("value")
                if isinstance(val, (int, float)):
                    val = [val] * 3
                try:
                    text = ", ".join(_number(x, keys) for x in val)
                except TypeError:
                    raise Error("%s: an rgb value is 3 numbers" % _path(keys)) from None
                self.emit(depth, "<rgb name=%s value=%s/>" % (name, quoteattr(text)), keys)
            elif t == "spectrum":
                val = v.get("value")
                if isinstance(val, (int, float)):
                    text = _number(val, keys)
                else:
                    text = ", ".join("%s:%s" % (_number(a, keys), _number(b, keys)) for a, b in val)
                self.emit(depth, "<spectrum name=%s value=%s/>" % (name, quoteattr(text)), keys)
            elif t == "ref":
                if "id" not in v:
                    raise Error("%s: a ref needs an 'id'" % _path(keys))
                self.emit(depth, "<ref name=%s id=%s/>" % (name, quoteattr(str(v["id"]))), keys)
            else:
                self.obj(v, depth, k, keys, top)
            return
        if k == "data" and _is_image(v):
            self.images.append((self.ids[-1], "data", v))
            return
        if top:
            raise Error("%s: a scene holds objects (dicts with a 'type'), not %r" % (_path(keys), type(v).__name__))
        if isinstance(v, bool):
            self.emit(depth, "<boolean name=%s value=%s/>" % (name, quoteattr("true" if v else "false")), keys)
        elif isinstance(v, int):
            self.emit(depth, "<integer name=%s value=%s/>" % (name, quoteattr(str(v))), keys)
        elif isinstance(v, float):
            self.emit(depth, "<float name=%s value=%s/>" % (name, quoteattr(_number(v, keys))), keys)
        elif isinstance(v, str):
            self.emit(depth, "<string name=%s value=%s/>" % (name, quoteattr(v)), keys)
        else:
            m = _matrix(v)
            if m is not None:
                text = " ".join(_number(x, keys) for x in m)
                self.emit(depth, "<transform name=%s><matrix value=%s/></transform>" % (name, quoteattr(text)), keys)
                return
            try:
                xs = [float(x) for x in v]
            except (TypeError, ValueError):
                raise Error("%s: cannot use a %s as a scene value" % (_path(keys), type(v).__name__)) from None
            if len(xs) != 3:
                raise Error("%s: %d numbers; give 3 (a colour or a point) or a 4x4 matrix" % (_path(keys), len(xs)))
            x, y, z = (_number(c, keys) for c in xs)
            if k in _POINT_NAMES:
                self.emit(depth, "<point name=%s x=%s y=%s z=%s/>" % (name, quoteattr(x), quoteattr(y), quoteattr(z)), keys)
            else:
                self.emit(depth, "<rgb name=%s value=%s/>" % (name, quoteattr("%s, %s, %s" % (x, y, z))), keys)


def to_xml(d):
    """The Mitsuba XML text of dict ``d`` and the key path of each line."""
    if not isinstance(d, dict) or d.get("type") != "scene":
        raise Error("load_dict: the top level is a dict with 'type': 'scene'")
    w = _Writer()
    w.emit(0, '<scene version="3.0.0">', [])
    w.members(d, 1, [], top=True)
    w.emit(0, "</scene>", [])
    return "\n".join(w.lines) + "\n", w.keys, w.images


def load_dict(d, base_dir=None):
    """Loads a scene given in Mitsuba 3's dictionary form (see the module's
    documentation); relative file names resolve from ``base_dir``."""
    xml, keys, images = to_xml(d)
    try:
        return _load_string(xml, {}, None if base_dir is None else str(base_dir), "<dict>", images)
    except Error as e:
        line = getattr(e, "line", None)
        if getattr(e, "file", None) and e.file.endswith("<dict>") and line and 1 <= line <= len(keys):
            err = Error("%s: %s" % (_path(keys[line - 1]), e.message))
            err.file, err.line, err.column, err.message = None, None, None, e.message
            err.key = keys[line - 1]
            raise err from None
        raise
