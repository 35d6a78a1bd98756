#!/usr/bin/env python3
"""Writes Bitterli's veach-mis as Mitsuba XML with the materials of its
original Tungsten scene, from the pbrt-v4 conversion (GitHub gonsolo/bitterli,
fetched, not bundled).

That conversion keeps the geometry, lights and camera but not the plates'
material: Tungsten's plates are copper with albedo 0.3 and a Beckmann
distribution of alpha = roughness (0.01, 0.05, 0.1, 0.25), while the pbrt-v4
file has copper at full strength with Trowbridge-Reitz (pbrt-v4 has no
Beckmann). So `TungstenRender.exr` is the reference of this XML, not of the
pbrt file. The README's table gives both comparisons.

    tools/veach-mis-tungsten.py veach-mis/pbrt/scene-v4.pbrt out-dir [width height]
    penumbra render out-dir/veach-mis.xml -o v.exr --spp 256

Meshes are written as OBJ files beside the XML (flat faces, as the pbrt
file's per-face normals give them). max_depth 4 = pbrt's maxdepth 3 + 1.
"""

import os
import re
import sys

ROUGHNESS = {"Smooth": 0.01, "Glossy": 0.05, "Rough": 0.1, "SuperRough": 0.25}


def main(src, out_dir, width=640, height=360):
    text = open(src).read()
    os.makedirs(out_dir, exist_ok=True)
    xml = [
        '<scene version="3.0.0">',
        '  <integrator type="path"><integer name="max_depth" value="4"/></integrator>',
        '  <sensor type="perspective">',
        '    <float name="fov" value="20.114292"/><string name="fov_axis" value="smaller"/>',
        '    <transform name="to_world"><lookat origin="28.2792, 3.5, 0" target="27.2792, 3.5, 0" up="0, 1, 0"/></transform>',
        '    <sampler type="independent"><integer name="sample_count" value="64"/></sampler>',
        f'    <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/>'
        '<rfilter type="tent"/></film>',
        "  </sensor>",
    ]
    for name, alpha in ROUGHNESS.items():
        xml.append(
            f'  <bsdf type="roughconductor" id="{name}"><string name="distribution" value="beckmann"/>'
            f'<float name="alpha" value="{alpha}"/><rgb name="eta" value="0.200438, 0.924033, 1.102212"/>'
            '<rgb name="k" value="3.912949, 2.452848, 2.142188"/><rgb name="specular_reflectance" value="0.3"/></bsdf>'
        )
    xml.append('  <bsdf type="diffuse" id="Diffuse"><rgb name="reflectance" value="0.5"/></bsdf>')
    material, meshes = None, 0
    world = text.split("WorldBegin", 1)[1]
    for block in re.split(r"\n(?=NamedMaterial|Shape|AttributeBegin)", world):
        m = re.match(r'NamedMaterial "(\w+)"', block)
        if m:
            material, block = m.group(1), block[m.end():].lstrip()
        if block.startswith('Shape "trianglemesh"'):
            p = [float(x) for x in re.search(r'"point3 P" \[([^\]]*)\]', block).group(1).split()]
            idx = [int(x) for x in re.search(r'"integer indices" \[([^\]]*)\]', block).group(1).split()]
            name = f"mesh{meshes}.obj"
            meshes += 1
            with open(os.path.join(out_dir, name), "w") as f:
                for i in range(0, len(p), 3):
                    f.write("v %r %r %r\n" % tuple(p[i:i + 3]))
                for i in range(0, len(idx), 3):
                    f.write("f %d %d %d\n" % (idx[i] + 1, idx[i + 1] + 1, idx[i + 2] + 1))
            xml.append(f'  <shape type="obj"><string name="filename" value="{name}"/>'
                       f'<boolean name="face_normals" value="true"/><ref id="{material}"/></shape>')
        elif block.startswith("AttributeBegin") and "AreaLightSource" in block:
            radiance = re.search(r'"rgb L" \[ *([\d.]+)', block).group(1)
            t = [float(x) for x in re.search(r"Transform \[([^\]]*)\]", block).group(1).split()]
            radius = re.search(r'"float radius" \[ *([\d.]+)', block).group(1)
            xml.append(f'  <shape type="sphere"><point name="center" x="{t[12]}" y="{t[13]}" z="{t[14]}"/>'
                       f'<float name="radius" value="{radius}"/><emitter type="area"><rgb name="radiance" value="{radiance}"/>'
                       '</emitter><bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf></shape>')
    xml.append("</scene>")
    if meshes != 6 or sum("sphere" in line for line in xml) != 3:
        sys.exit(f"{src}: expected 6 meshes and 3 sphere lights, found {meshes}: not the veach-mis file")
    with open(os.path.join(out_dir, "veach-mis.xml"), "w") as f:
        f.write("\n".join(xml) + "\n")


if __name__ == "__main__":
    if len(sys.argv) not in (3, 5):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], *map(int, sys.argv[3:]))
