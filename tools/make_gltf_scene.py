#!/usr/bin/env python3
"""Writes the glTF test scene tests/scenes/gltf/boxes.gltf (+ boxes.bin) and
the same scene as Mitsuba XML (boxes.xml), for the cross-format test in
crates/scene/tests/gltf.rs. Only diffuse surfaces (glTF: metallic 0 and
KHR_materials_specular's specularFactor 0, which is Lambertian), an emissive
quad, a point, a spot and a directional light and a perspective camera, so both formats describe
exactly the same image. Asymmetric (red box left, blue box right, light on
the right) so that a mirrored camera shows. Run from the repository root."""
import json, math, struct

OUT = "tests/scenes/gltf/"

def cube():
    # 24 vertices [-1,1]^3, outward normals, counter-clockwise seen from outside.
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (1, -1):
            n = [0, 0, 0]; n[axis] = sign
            u = [0, 0, 0]; u[(axis + 1) % 3] = 1
            v = [0, 0, 0]; v[(axis + 2) % 3] = 1
            if sign < 0:
                u, v = v, u
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                pos.append([n[i] + a * u[i] + b * v[i] for i in range(3)])
                nrm.append(n)
            idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, idx

def quad(normal_down):
    # [-1,1]^2 in the xz plane, normal +y (or -y).
    pos = [[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]
    idx = [0, 2, 1, 0, 3, 2] if not normal_down else [0, 1, 2, 0, 2, 3]
    n = [0, -1, 0] if normal_down else [0, 1, 0]
    return pos, [n] * 4, idx

blob = bytearray()
views, accessors = [], []

def add(data, fmt, count, comp, typ, target, minmax=None):
    global blob
    while len(blob) % 4:
        blob += b"\0"
    off = len(blob)
    blob += struct.pack("<" + fmt * (len(data)), *data)
    views.append({"buffer": 0, "byteOffset": off, "byteLength": len(blob) - off, "target": target})
    acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": typ}
    if minmax:
        acc["min"], acc["max"] = minmax
    accessors.append(acc)
    return len(accessors) - 1

def mesh(pos, nrm, idx):
    flat = [c for p in pos for c in p]
    mm = ([min(p[i] for p in pos) for i in range(3)], [max(p[i] for p in pos) for i in range(3)])
    a_pos = add(flat, "f", len(pos), 5126, "VEC3", 34962, mm)
    a_nrm = add([c for n in nrm for c in n], "f", len(nrm), 5126, "VEC3", 34962)
    a_idx = add(idx, "H", len(idx), 5123, "SCALAR", 34963)
    return a_pos, a_nrm, a_idx

def diffuse(name, rgb):
    return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": rgb + [1], "metallicFactor": 0, "roughnessFactor": 1},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0}}}

GREY, RED, BLUE = [0.7, 0.7, 0.7], [0.8, 0.1, 0.1], [0.1, 0.2, 0.8]
EMIT = 4.0
LIGHT_POS, LIGHT_RGB, LIGHT_I = [0.6, 1.0, 0.8], [1.0, 0.9, 0.8], 2.0
CAM_POS, CAM_PITCH, YFOV, ASPECT = [0.0, 1.0, 3.0], -15.0, 0.8, 4 / 3
# A spot straight down onto the blue box, and a directional light from the left.
SPOT_POS, SPOT_RGB, SPOT_I, SPOT_INNER, SPOT_OUTER = [0.45, 2.0, -0.2], [0.6, 0.8, 1.0], 3.0, 0.15, 0.35
SUN_DIR = [0.8, -1.0, -0.4]
SUN_RGB, SUN_I = [1.0, 0.8, 0.6], 0.4

def quat_from_to(a, b):
    """The rotation taking unit vector a to the direction of b, as glTF's [x, y, z, w]."""
    n = math.sqrt(sum(x * x for x in b))
    b = [x / n for x in b]
    c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    d = sum(a[i] * b[i] for i in range(3))
    q = c + [1 + d]
    m = math.sqrt(sum(x * x for x in q))
    return [x / m for x in q]

materials = [diffuse("floor", GREY), diffuse("red", RED), diffuse("blue", BLUE),
             {"name": "lamp", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
              "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": EMIT}}}]
meshes = []
for geo, mat in ((quad(False), 0), (cube(), 1), (cube(), 2), (quad(True), 3)):
    p, n, i = mesh(*geo)
    meshes.append({"primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i, "material": mat}]})

def quat_y(deg):
    h = math.radians(deg) / 2
    return [0, math.sin(h), 0, math.cos(h)]

def quat_x(deg):
    h = math.radians(deg) / 2
    return [math.sin(h), 0, 0, math.cos(h)]

# The blue box by a column-major matrix: scale (0.3, 0.6, 0.3), translate (0.45, 0.6, -0.2).
blue_matrix = [0.3, 0, 0, 0, 0, 0.6, 0, 0, 0, 0, 0.3, 0, 0.45, 0.6, -0.2, 1]
nodes = [
    {"name": "floor", "mesh": 0, "scale": [1.5, 1, 1.5]},
    # A parent node carries the red box's translation (hierarchy test).
    {"name": "red_parent", "translation": [-0.45, 0.0, 0.1], "children": [2]},
    {"name": "red", "mesh": 1, "translation": [0, 0.25, 0], "rotation": quat_y(30), "scale": [0.25, 0.25, 0.25]},
    {"name": "blue", "mesh": 2, "matrix": blue_matrix},
    {"name": "lamp", "mesh": 3, "translation": [0, 1.5, 0], "scale": [0.3, 1, 0.3]},
    {"name": "point", "translation": LIGHT_POS, "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "camera", "camera": 0, "translation": CAM_POS, "rotation": quat_x(CAM_PITCH)},
    {"name": "spot", "translation": SPOT_POS, "rotation": quat_x(-90), "extensions": {"KHR_lights_punctual": {"light": 1}}},
    {"name": "sun", "rotation": quat_from_to([0, 0, -1], SUN_DIR), "extensions": {"KHR_lights_punctual": {"light": 2}}},
]
doc = {
    "asset": {"version": "2.0", "generator": "tools/make_gltf_scene.py"},
    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_specular"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": LIGHT_RGB, "intensity": LIGHT_I},
        {"type": "spot", "color": SPOT_RGB, "intensity": SPOT_I,
         "spot": {"innerConeAngle": SPOT_INNER, "outerConeAngle": SPOT_OUTER}},
        {"type": "directional", "color": SUN_RGB, "intensity": SUN_I}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 3, 4, 5, 6, 7, 8]}],
    "nodes": nodes,
    "cameras": [{"type": "perspective", "perspective": {"yfov": YFOV, "aspectRatio": ASPECT, "znear": 0.01}}],
    "meshes": meshes,
    "materials": materials,
    "buffers": [{"uri": "boxes.bin", "byteLength": len(blob)}],
    "bufferViews": views,
    "accessors": accessors,
}
open(OUT + "boxes.bin", "wb").write(blob)
open(OUT + "boxes.gltf", "w").write(json.dumps(doc, indent=1) + "\n")

# The same scene in Mitsuba XML, written independently of Penumbra's glTF
# conversion: the camera by lookat, the boxes by Mitsuba's cube, the quads
# by rectangles rotated into the xz plane.
p = math.radians(CAM_PITCH)
fwd = [0, math.sin(p), -math.cos(p)]
up = [0, math.cos(p), math.sin(p)]
target = [CAM_POS[i] + fwd[i] for i in range(3)]
v3 = lambda v: ", ".join(f"{x:.9g}" for x in v)
rgb = lambda c: ", ".join(f"{x:.9g}" for x in c)
xml = f"""<scene version="3.0.0">
    <!-- Written by tools/make_gltf_scene.py: the Mitsuba twin of boxes.gltf. -->
    <default name="spp" value="64"/>
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="{math.degrees(YFOV):.9g}"/>
        <string name="fov_axis" value="y"/>
        <float name="near_clip" value="0.01"/>
        <transform name="to_world">
            <lookat origin="{v3(CAM_POS)}" target="{v3(target)}" up="{v3(up)}"/>
        </transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="512"/>
            <integer name="height" value="384"/>
            <rfilter type="gaussian"/>
        </film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale x="1.5" z="1.5"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="{rgb(GREY)}"/></bsdf>
    </shape>
    <shape type="cube">
        <transform name="to_world">
            <scale value="0.25"/><rotate y="1" angle="30"/><translate y="0.25"/><translate x="-0.45" z="0.1"/>
        </transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="{rgb(RED)}"/></bsdf>
    </shape>
    <shape type="cube">
        <transform name="to_world"><scale x="0.3" y="0.6" z="0.3"/><translate x="0.45" y="0.6" z="-0.2"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="{rgb(BLUE)}"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="90"/><scale x="0.3" z="0.3"/><translate y="1.5"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="{EMIT}"/></emitter>
    </shape>
    <emitter type="point">
        <point name="position" value="{v3(LIGHT_POS)}"/>
        <rgb name="intensity" value="{rgb([c * LIGHT_I for c in LIGHT_RGB])}"/>
    </emitter>
    <emitter type="spot">
        <transform name="to_world">
            <lookat origin="{v3(SPOT_POS)}" target="{v3([SPOT_POS[0], 0, SPOT_POS[2]])}" up="0, 0, 1"/>
        </transform>
        <float name="cutoff_angle" value="{math.degrees(SPOT_OUTER):.9g}"/>
        <float name="beam_width" value="{math.degrees(SPOT_INNER):.9g}"/>
        <rgb name="intensity" value="{rgb([c * SPOT_I for c in SPOT_RGB])}"/>
    </emitter>
    <emitter type="directional">
        <vector name="direction" value="{v3(SUN_DIR)}"/>
        <rgb name="irradiance" value="{rgb([c * SUN_I for c in SUN_RGB])}"/>
    </emitter>
</scene>
"""
open(OUT + "boxes.xml", "w").write(xml)
print("wrote", OUT + "boxes.gltf", len(blob), "bytes of buffer, and boxes.xml")

# ---------------------------------------------------------------------------
# materials.gltf: the metallic-roughness material (a gold metal, a glossy red
# dielectric, a KHR_materials_transmission glass) on instanced spheres over a
# floor with an sRGB checker texture (a PNG in a bufferView, repeated 4x by
# KHR_texture_transform); a directional and a spot light; a camera looking
# down at 30 degrees. README's image; crates/scene/tests/gltf.rs checks the texture.
import zlib

def png(w, h, rows):
    def chunk(t, d):
        c = struct.pack(">I", len(d)) + t + d
        return c + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    raw = b"".join(b"\0" + bytes(r) for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))

CHECK = (200, 60)  # sRGB-encoded bytes of the light and dark squares
rows = [[c for x in range(8) for c in [CHECK[(x + y) % 2]] * 3] for y in range(8)]
png_bytes = png(8, 8, rows)

blob = bytearray()
views, accessors = [], []

def sphere(nu=24, nv=12):
    pos, nrm, uv, idx = [], [], [], []
    for j in range(nv + 1):
        t = math.pi * j / nv
        for i in range(nu + 1):
            p = 2 * math.pi * i / nu
            n = [math.sin(t) * math.cos(p), math.cos(t), -math.sin(t) * math.sin(p)]
            pos.append(n); nrm.append(n); uv.append([i / nu, j / nv])
    for j in range(nv):
        for i in range(nu):
            a, b = j * (nu + 1) + i, (j + 1) * (nu + 1) + i
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, nrm, uv, idx

def mesh_uv(pos, nrm, uv, idx):
    a_pos, a_nrm, a_idx = mesh(pos, nrm, idx)
    a_uv = add([c for t in uv for c in t], "f", len(uv), 5126, "VEC2", 34962)
    return a_pos, a_nrm, a_uv, a_idx

fp, fn, fi = quad(False)
floor = mesh_uv(fp, fn, [[0, 0], [1, 0], [1, 1], [0, 1]], fi)
ball = mesh_uv(*sphere())
while len(blob) % 4:
    blob += b"\0"
img_off = len(blob)
blob += png_bytes
views.append({"buffer": 0, "byteOffset": img_off, "byteLength": len(png_bytes)})
img_view = len(views) - 1

def prim(m, mat):
    return {"primitives": [{"attributes": {"POSITION": m[0], "NORMAL": m[1], "TEXCOORD_0": m[2]}, "indices": m[3], "material": mat}]}

doc2 = {
    "asset": {"version": "2.0", "generator": "tools/make_gltf_scene.py"},
    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior", "KHR_texture_transform"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"type": "directional", "color": [1, 0.95, 0.9], "intensity": 2.5},
        {"type": "spot", "color": [0.6, 0.7, 1.0], "intensity": 6, "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3, 4, 5, 6]}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.6, "aspectRatio": 1.5, "znear": 0.01}}],
    "nodes": [
        {"name": "floor", "mesh": 0, "scale": [2.2, 1, 1.4]},
        {"name": "gold", "mesh": 1, "translation": [-1.1, 0.45, 0], "scale": [0.45, 0.45, 0.45]},
        {"name": "red", "mesh": 2, "translation": [0, 0.45, 0], "scale": [0.45, 0.45, 0.45]},
        {"name": "glass", "mesh": 3, "translation": [1.1, 0.45, 0], "scale": [0.45, 0.45, 0.45]},
        # The sun from the upper left front: its −z turned towards (0.5, −1, −0.6).
        {"name": "sun", "rotation": [-0.4, -0.2, -0.1, 0.89], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        # A spot straight down onto the red ball (−z turned to −y).
        {"name": "spot", "translation": [0, 2.5, 0], "rotation": [-0.7071068, 0, 0, 0.7071068],
         "extensions": {"KHR_lights_punctual": {"light": 1}}},
        {"name": "camera", "camera": 0, "translation": [0, 2.3, 3.6], "rotation": quat_x(-30)},
    ],
    "meshes": [prim(floor, 0), prim(ball, 1), prim(ball, 2), prim(ball, 3)],
    "materials": [
        {"name": "checker", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 0.7,
         "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [4, 4]}}}}},
        {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.77, 0.34, 1], "metallicFactor": 1, "roughnessFactor": 0.35}},
        {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.08, 0.06, 1], "metallicFactor": 0, "roughnessFactor": 0.25}},
        {"name": "glass", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 0.05},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1}, "KHR_materials_ior": {"ior": 1.5}}},
    ],
    "textures": [{"source": 0, "sampler": 0}],
    "samplers": [{"magFilter": 9728, "wrapS": 10497, "wrapT": 10497}],
    "images": [{"bufferView": img_view, "mimeType": "image/png"}],
    "buffers": [{"uri": "materials.bin", "byteLength": len(blob)}],
    "bufferViews": views,
    "accessors": accessors,
}
open(OUT + "materials.bin", "wb").write(blob)
open(OUT + "materials.gltf", "w").write(json.dumps(doc2, indent=1) + "\n")
print("wrote", OUT + "materials.gltf", len(blob), "bytes of buffer")
