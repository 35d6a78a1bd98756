#!/usr/bin/env python3
"""Mitsuba 3.9.1's values for the 1x1 sensor scenes of
crates/scene/tests/sensors.rs (`irradiancemeter`, `distant`), whose output
is a number, not an image.

Usage:
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        .venv-mitsuba/bin/python tools/meter_refs.py

For each scene: 8 renders of 4096 spp with seeds 0..7 (llvm_ad_rgb, 2
threads); prints the mean of the 8 and its standard error per channel, the
numbers MITSUBA_* in sensors.rs hold. The scenes here and there must stay
the same text.
"""
import drjit as dr

dr.set_thread_count(2)
import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")
import numpy as np  # noqa: E402

FILM = ('<sampler type="independent"><integer name="sample_count" value="4096"/></sampler>'
        '<film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="1"/>'
        '<rfilter type="box"/></film>')

# The scene of sensors.rs's `distant_scene`: a unit rectangle emitter facing
# +z (radiance 1, 2, 3) above a diffuse sphere, seen along -z.
DISTANT = ('<scene version="3.0.0"><integrator type="path"/>\n'
           '<sensor type="distant"><vector name="direction" x="0" y="0" z="-1"/>{target}' + FILM + '</sensor>\n'
           '<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>\n'
           '<shape type="sphere"><point name="center" x="0" y="0" z="-3"/><float name="radius" value="0.5"/></shape>\n'
           '</scene>')
SCENES = {
    "distant, shape target": DISTANT.format(target='<shape type="rectangle" name="target"><transform name="to_world">'
                                            '<scale value="2"/><translate x="0.5"/></transform></shape>'),
    "distant, no target": DISTANT.format(target=""),
    # sensors.rs's `irradiancemeter_matches_mitsuba`: a rectangle meter
    # tilted under a disk lamp, beside a diffuse sphere, in a dim sky.
    "irradiancemeter": (
        '<scene version="3.0.0"><integrator type="path"/>\n'
        '<emitter type="constant"><rgb name="radiance" value="0.1, 0.2, 0.3"/></emitter>\n'
        '<shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="30"/></transform>'
        '<sensor type="irradiancemeter">' + FILM + '</sensor></shape>\n'
        '<shape type="disk"><transform name="to_world"><scale value="1.5"/><rotate x="1" angle="180"/>'
        '<translate z="2"/></transform><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>\n'
        '<shape type="sphere"><point name="center" x="1" y="0" z="0.5"/><float name="radius" value="0.5"/></shape>\n'
        '</scene>'),
}

for name, xml in SCENES.items():
    scene = mi.load_string(xml)
    v = np.array([np.array(mi.render(scene, spp=4096, seed=k)).reshape(-1)[:3] for k in range(8)], dtype=np.float64)
    mean, se = v.mean(0), v.std(0, ddof=1) / np.sqrt(len(v))
    print(f"{name}: mean {np.array2string(mean, precision=6)} se {np.array2string(se, precision=6)}")
