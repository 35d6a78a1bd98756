#!/usr/bin/env python3
"""Write tests/scenes/shapes/three.serialized from meshes Mitsuba 3.9.1 builds,
check that Mitsuba reads the file back and renders it as it renders the source
meshes, and print the values crates/scene/tests/shapes.rs asserts.

Mitsuba 3 has no writer for its `.serialized` format (its Python API offers
`Mesh.write_ply` only), so the file is written here from the format that
Mitsuba 3.9.1's src/shapes/serialized.cpp reads: per mesh `u16` 0x041C,
`u16` version 4, then a zlib stream of `u32` flags, a NUL-terminated name,
`u64` vertex and face counts, positions, optional normals and texture
coordinates (f32, or f64 with flag 0x2000) and `u32` indices; the file ends
with the `u64` byte offset of each mesh and a `u32` mesh count.

The three meshes, each taken from the buffers of a Mitsuba-built mesh:
  0 "cube"         Mitsuba's `cube` under a rotate and scale: normals and uvs,
                   single precision
  1 "panel"        Mitsuba's `rectangle` under a rotate, scale and translate:
                   normals and uvs, double precision (flag 0x2000)
  2 "icosahedron"  tests/scenes/meshes/icosahedron.ply as Mitsuba's `ply`
                   loads it with face_normals, positions only, with the file
                   flag 0x0010 (face normals) set; Mitsuba 3.9.1 ignores that
                   flag (the shape's own `face_normals` property decides), so
                   it is read back and rendered with face_normals true

Usage: .venv-mitsuba/bin/python tools/make_serialized_fixture.py
(Mitsuba setup: ../shared/reference-renderer.md, or `pip install mitsuba==3.9.1 numpy`)
"""
import os
import struct
import sys
import zlib

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
OUT = os.path.join(ROOT, "tests", "scenes", "shapes", "three.serialized")
ICO = os.path.join(ROOT, "tests", "scenes", "meshes", "icosahedron.ply")

HAS_NORMALS, HAS_TEXCOORDS, FACE_NORMALS = 0x0001, 0x0002, 0x0010
SINGLE, DOUBLE = 0x1000, 0x2000

T = mi.ScalarTransform4f
SOURCES = [
    ("cube", {"type": "cube", "to_world": T().translate([-0.9, 0.0, 0.0]).rotate([0, 1, 0], 30).scale([0.5, 0.3, 0.4])},
     SINGLE | HAS_NORMALS | HAS_TEXCOORDS),
    ("panel", {"type": "rectangle",
               "to_world": T().translate([0.0, -0.6, 0.2]).rotate([1, 0, 0], -70).scale([1.4, 0.8, 1.0])},
     DOUBLE | HAS_NORMALS | HAS_TEXCOORDS),
    ("icosahedron", {"type": "ply", "filename": ICO, "face_normals": True,
                     "to_world": T().translate([0.8, 0.1, 0.0]).scale(0.45)},
     SINGLE | FACE_NORMALS),
]


def buffers(mesh):
    pos = np.array(mesh.vertex_positions_buffer(), dtype=np.float32).reshape(-1, 3)
    nrm = np.array(mesh.vertex_normals_buffer(), dtype=np.float32).reshape(-1, 3) if mesh.has_vertex_normals() else None
    uv = np.array(mesh.vertex_texcoords_buffer(), dtype=np.float32).reshape(-1, 2) if mesh.has_vertex_texcoords() else None
    faces = np.array(mesh.faces_buffer(), dtype=np.uint32).reshape(-1, 3)
    return pos, nrm, uv, faces


def mesh_blob(name, mesh, flags):
    pos, nrm, uv, faces = buffers(mesh)
    real = np.dtype("<f8" if flags & DOUBLE else "<f4")
    body = struct.pack("<I", flags) + name.encode() + b"\0"
    body += struct.pack("<QQ", len(pos), len(faces))
    body += pos.astype(real).tobytes()
    if flags & HAS_NORMALS:
        body += nrm.astype(real).tobytes()
    if flags & HAS_TEXCOORDS:
        body += uv.astype(real).tobytes()
    body += faces.astype("<u4").tobytes()
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(body, 9)


def write(meshes):
    data, offsets = b"", []
    for name, mesh, flags in meshes:
        offsets.append(len(data))
        data += mesh_blob(name, mesh, flags)
    data += b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack("<I", len(offsets))
    with open(OUT, "wb") as f:
        f.write(data)
    return len(data)


def scene(shapes):
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {
            "type": "perspective", "fov": 45,
            "to_world": T().look_at(origin=[0.5, 1.5, 4.0], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": 48, "height": 32, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": 16},
        },
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.6, 0.7, 0.8]}},
        "light": {"type": "point", "position": [1.0, 3.0, 2.0], "intensity": {"type": "rgb", "value": [8.0, 7.0, 6.0]}},
    }
    for k, s in enumerate(shapes):
        d[f"shape{k}"] = dict(s, bsdf={"type": "twosided", "bsdf": {"type": "diffuse"}})
    return mi.load_dict(d)


def serialized(i):
    d = {"type": "serialized", "filename": OUT, "shape_index": i}
    if SOURCES[i][2] & FACE_NORMALS:
        d["face_normals"] = True
    return d


def main():
    meshes = [(name, mi.load_dict(src), flags) for name, src, flags in SOURCES]
    size = write(meshes)
    print(f"wrote {os.path.relpath(OUT, ROOT)} ({size} bytes)")

    ok = True
    read = []
    for i, (name, mesh, flags) in enumerate(meshes):
        s = mi.load_dict(serialized(i))
        read.append(s)
        a, b = buffers(mesh), buffers(s)
        same_pos = np.array_equal(a[0], b[0]) and np.array_equal(a[3], b[3])
        same_attr = all((x is None and y is None) or (x is not None and y is not None and np.array_equal(x, y))
                        for x, y in ((a[1], b[1]), (a[2], b[2])))
        if flags & FACE_NORMALS:
            same_attr = same_attr and not s.has_vertex_normals()
        ok &= same_pos and same_attr
        bb = s.bbox()
        print(f"mesh {i} {name!r}: {s.vertex_count()} vertices, {s.face_count()} faces, "
              f"normals {s.has_vertex_normals()}, uvs {s.has_vertex_texcoords()}, "
              f"read back identical: {same_pos and same_attr}")
        print(f"    bbox min [{', '.join(repr(float(x)) for x in bb.min)}]")
        print(f"    bbox max [{', '.join(repr(float(x)) for x in bb.max)}]")
        print(f"    sum of positions [{', '.join(repr(float(x)) for x in b[0].astype(np.float64).sum(axis=0))}]")
    try:
        mi.load_dict({"type": "serialized", "filename": OUT, "shape_index": len(meshes)})
        print(f"shape_index {len(meshes)}: loaded (unexpected)")
        ok = False
    except Exception as e:  # Mitsuba raises for an index past the last mesh
        print(f"shape_index {len(meshes)}: Mitsuba refuses it ({str(e).replace(ROOT + '/', '')})")

    srcs = [src for _, src, _ in SOURCES]
    sers = [serialized(i) for i in range(len(SOURCES))]
    img_src = np.array(mi.render(scene(srcs), seed=7))
    img_ser = np.array(mi.render(scene(sers), seed=7))
    diff = float(np.abs(img_src - img_ser).max())
    print(f"render, source meshes vs three.serialized (48x32, 16 spp, seed 7): mean {img_src.mean():.6f} vs "
          f"{img_ser.mean():.6f}, max |difference| {diff}")
    ok &= diff == 0.0
    print("OK" if ok else "MISMATCH")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
