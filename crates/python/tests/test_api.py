"""The Python API against the command line, closed forms and itself."""

import math
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import penumbra


def bits(a):
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


ROOT = __import__("pathlib").Path(__file__).resolve().parents[3]
PBRT_SCENE = ROOT / "scenes" / "pbrt" / "cornell.pbrt"


def run_cli(cli, *args):
    subprocess.run([cli, "render", "--quiet", *map(str, args)], check=True, capture_output=True)


def test_render_is_bitwise_the_command_line_image(cli, cbox, tmp_path):
    out = tmp_path / "cli.exr"
    run_cli(cli, cbox, "-D", "res=48", "--spp", 6, "--seed", 5, "-o", out)
    scene = penumbra.load_file(cbox, res=48)
    assert (scene.width, scene.height) == (48, 48)
    img = penumbra.render(scene, spp=6, seed=5, progress=False)
    assert img.shape == (48, 48, 3) and img.dtype == np.float32
    ref = penumbra.read(out)
    assert np.array_equal(bits(img), bits(ref))
    # Another seed is another image: the comparison above can fail.
    other = penumbra.render(scene, spp=6, seed=6, progress=False)
    assert not np.array_equal(bits(other), bits(ref))


def test_aovs_are_the_command_line_layers(cli, cbox, tmp_path):
    out = tmp_path / "cli.exr"
    run_cli(cli, cbox, "-D", "res=32", "--spp", 4, "--aov", "albedo,depth,variance", "-o", out)
    scene = penumbra.load_file(cbox, res=32)
    got = penumbra.render(scene, spp=4, aovs=("albedo", "depth", "variance"), progress=False)
    ref = penumbra.read(out, metadata=True)
    assert set(got) == {"image", "albedo", "depth", "variance"}
    assert got["albedo"].shape == (32, 32, 3) and got["depth"].shape == (32, 32, 1)
    for k in got:
        assert np.array_equal(bits(got[k]), bits(ref[k])), k
    assert ref["metadata"]["spp"] == "4"


def test_integrator_channels_are_the_command_line_layers(cli, tmp_path):
    scenes = os.path.join(os.path.dirname(__file__), "..", "..", "..", "tests", "scenes")
    for name, spp in (("aov_channels.xml", 2), ("moment_cbox.xml", 2)):
        path = os.path.join(scenes, name)
        out = tmp_path / (name + ".exr")
        run_cli(cli, path, "--spp", spp, "-o", out)
        got = penumbra.render(penumbra.load_file(path), spp=spp, progress=False)
        ref = penumbra.read(out, metadata=True)
        assert isinstance(got, dict) and len(got) > 1, name
        assert set(got) == set(ref) - {"metadata"}, (name, set(got), set(ref))
        for k in got:
            assert np.array_equal(bits(got[k]), bits(ref[k])), (name, k)


def test_integrator_and_threads(cli, cbox, tmp_path):
    out = tmp_path / "cli.exr"
    run_cli(cli, cbox, "-D", "res=24", "--spp", 3, "--integrator", "direct:emitter_samples=2", "--threads", 1, "-o", out)
    scene = penumbra.load_file(cbox, res=24)
    img = penumbra.render(scene, spp=3, integrator="direct:emitter_samples=2", threads=2, progress=False)
    assert np.array_equal(bits(img), bits(penumbra.read(out)))


FURNACE = {
    "type": "scene",
    "integrator": {"type": "path", "max_depth": -1, "rr_depth": 1000},
    "sensor": {
        "type": "perspective",
        "fov": 30.0,
        "to_world": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -4], [0, 0, 0, 1]],
        "film": {"type": "hdrfilm", "width": 24, "height": 24, "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": 16},
    },
    "light": {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
    "ball": {
        "type": "sphere",
        "radius": 1.0,
        "center": [0, 0, 0],
        "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
    },
}


def test_load_dict_furnace_renders_one():
    """A white diffuse sphere under a white sky: every pixel's expectation is
    exactly 1. The image mean is tested against the spread of its (box
    filtered, so independent) pixels at a false-alarm rate of 1e-4 per channel."""
    img = penumbra.render(penumbra.load_dict(FURNACE), progress=False).reshape(-1, 3).astype(np.float64)
    n = img.shape[0]
    se = img.std(axis=0, ddof=1) / math.sqrt(n)
    z = np.abs(img.mean(axis=0) - 1.0) / np.maximum(se, 1e-12)
    assert np.all(z < 3.9), (img.mean(axis=0), se)
    # A 2 % darker sky would fail it (the test has the power to see it).
    d = dict(FURNACE, light={"type": "constant", "radiance": {"type": "rgb", "value": [0.98] * 3}})
    dark = penumbra.render(penumbra.load_dict(d), progress=False).reshape(-1, 3).astype(np.float64)
    assert np.all(np.abs(dark.mean(axis=0) - 1.0) / (dark.std(axis=0, ddof=1) / math.sqrt(n)) > 3.9)


def test_load_dict_equals_the_same_xml():
    xml, _, _ = penumbra._dict.to_xml(FURNACE)
    a = penumbra.render(penumbra.load_dict(FURNACE), spp=2, progress=False)
    b = penumbra.render(penumbra.load_string(xml), spp=2, progress=False)
    assert np.array_equal(bits(a), bits(b))
    assert 'id="ball"' in xml and '<point name="center"' in xml


def test_bad_input_raises_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n  <shape type="sphere">\n    <float name="radius" value="nan"/>\n  </shape>\n</scene>\n')
    with pytest.raises(penumbra.Error) as e:
        penumbra.load_file(bad)
    assert e.value.file.endswith("bad.xml") and e.value.line == 3 and "bad.xml:3:" in str(e.value)
    with pytest.raises(penumbra.Error) as e:
        penumbra.load_file(tmp_path / "missing.xml")
    assert "missing.xml" in str(e.value)
    with pytest.raises(penumbra.Error) as e:
        penumbra.load_string('<scene version="3.0.0">\n<bsdf type="diffuse" id="d">\n<float name="roughness" value="1"/>\n</bsdf></scene>')
    assert e.value.line == 3 and "roughness" in str(e.value)


def test_bad_dict_names_the_key():
    d = dict(FURNACE, ball=dict(FURNACE["ball"], bsdf={"type": "diffuse", "roughnes": 0.5}))
    with pytest.raises(penumbra.Error) as e:
        penumbra.load_dict(d)
    assert "dict['ball']['bsdf']['roughnes']" in str(e.value), str(e.value)
    with pytest.raises(penumbra.Error, match=r"dict\['ball'\]\['radius'\]: nan is not a finite number"):
        penumbra.load_dict(dict(FURNACE, ball=dict(FURNACE["ball"], radius=float("nan"))))
    with pytest.raises(penumbra.Error, match="not one Penumbra builds"):
        penumbra.load_dict(dict(FURNACE, pol={"type": "polarizer"}))
    # A medium is one (a top-level declaration, unused here).
    penumbra.load_dict(dict(FURNACE, fog={"type": "homogeneous", "sigma_t": 0.5}))


def test_parameter_sweep_keeps_geometry_and_matches_a_fresh_load(cbox):
    scene = penumbra.load_file(cbox, res=24)
    assert scene.get("red.reflectance") == [0.63, 0.065, 0.05]
    before = scene.geometry_builds
    base = penumbra.render(scene, spp=2, progress=False)
    scene.set("red.reflectance", [0.2, 0.2, 0.9])
    swept = penumbra.render(scene, spp=2, progress=False)
    assert scene.geometry_builds == before, "a reflectance change rebuilt geometry"
    assert not np.array_equal(bits(base), bits(swept))
    text = cbox.read_text().replace('<rgb name="reflectance" value="0.63, 0.065, 0.05"/>', '<rgb name="reflectance" value="0.2, 0.2, 0.9"/>')
    assert text != cbox.read_text()
    fresh = penumbra.load_string(text, base_dir=cbox.parent, res=24)
    assert np.array_equal(bits(swept), bits(penumbra.render(fresh, spp=2, progress=False)))
    # A shape's own parameter rebuilds that shape only (the BVH too).
    scene.set("sensor.to_world", np.eye(4))
    assert scene.geometry_builds == before
    assert np.array_equal(scene.camera_to_world, np.eye(4))
    with pytest.raises(penumbra.Error, match="no object with id 'nosuch'"):
        scene.set("nosuch.reflectance", 0.5)
    with pytest.raises(penumbra.Error, match="is a rgb"):
        scene.set("red.reflectance", "text")
    with pytest.raises(KeyError):
        scene.set("reflectance", 0.5)
    # Hostile numbers are refused, and the scene keeps its last good value.
    for bad in ([0.2, float("nan"), 0.9], float("inf"), 1e39):
        with pytest.raises(ValueError, match="must be finite numbers"):
            scene.set("red.reflectance", bad)


def test_progress_reaches_the_total(cbox):
    calls = []
    penumbra.render(penumbra.load_file(cbox, res=16), spp=4, progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1][0] == calls[-1][1] == 16 * 16 * 4
    assert all(a[0] <= b[0] for a, b in zip(calls, calls[1:]))


def test_the_gil_is_released_while_rendering(cbox):
    scene = penumbra.load_file(cbox, res=64)
    done = threading.Event()
    t = threading.Thread(target=lambda: (penumbra.render(scene, spp=64, threads=1, progress=False), done.set()))
    ticks = 0
    start = time.monotonic()
    t.start()
    while not done.is_set() and time.monotonic() - start < 60:
        ticks += 1
        time.sleep(0.001)
    t.join()
    # Held for the whole render, the GIL would let this loop run only at
    # the start and the end.
    assert ticks > 20, ticks


def os_threads():
    return len(os.listdir("/proc/self/task"))


def test_ctrl_c_interrupts_without_leaving_threads(cbox, tmp_path):
    scene = penumbra.load_file(cbox, res=96)
    threads_before = os_threads()
    ck = tmp_path / "render.ckpt"
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    # Python's Ctrl-C handler, as in an interactive session: a process
    # started in the background (`cmd &`, nohup) inherits SIGINT ignored,
    # and Python then installs no handler at all.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        t0 = time.monotonic()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            penumbra.render(scene, spp=4096, threads=2, progress=False, checkpoint=ck)
        assert time.monotonic() - t0 < 30
        timer.join()
    finally:
        signal.signal(signal.SIGINT, previous)
    deadline = time.monotonic() + 5
    while os_threads() > threads_before and time.monotonic() < deadline:
        time.sleep(0.05)
    assert os_threads() <= threads_before
    assert ck.exists(), "the interrupted render saved no checkpoint"


def test_checkpoint_resume_is_bitwise_the_uninterrupted_render(cbox, tmp_path):
    scene = penumbra.load_file(cbox, res=64)
    whole = penumbra.render(scene, spp=96, threads=1, progress=False)
    ck = tmp_path / "r.ckpt"
    # Interrupt after the first progress report past a third of the samples.
    def stop(done, total):
        if done > total // 3:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        penumbra.render(scene, spp=96, threads=1, progress=stop, checkpoint=ck)
    assert ck.exists()
    resumed = penumbra.render(scene, spp=96, threads=1, progress=False, checkpoint=ck)
    assert np.array_equal(bits(whole), bits(resumed))
    assert not ck.exists(), "a complete render keeps no checkpoint"


def test_read_and_write_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    img = rng.random((5, 7, 3), dtype=np.float32) * 4
    albedo = rng.random((5, 7, 3), dtype=np.float32)
    depth = rng.random((5, 7), dtype=np.float32)
    penumbra.write(tmp_path / "a.exr", img, layers={"albedo": albedo, "depth": depth}, metadata={"note": "hello"})
    back = penumbra.read(tmp_path / "a.exr", metadata=True)
    assert np.array_equal(back["image"], img) and np.array_equal(back["albedo"], albedo)
    assert np.array_equal(back["depth"][:, :, 0], depth) and back["metadata"]["note"] == "hello"
    for ext in ("pfm", "hdr", "png"):
        penumbra.write(tmp_path / ("a." + ext), img)
        got = penumbra.read(tmp_path / ("a." + ext))
        assert got.shape == img.shape
        if ext == "pfm":
            assert np.array_equal(got, img)
        elif ext == "hdr":  # RGBE: 8-bit mantissas under the largest channel's exponent
            assert np.all(np.abs(got - img) <= img.max(axis=2, keepdims=True) / 128)
        else:  # sRGB 8-bit, clamped to [0, 1]
            assert np.allclose(got, np.clip(img, 0, 1), atol=0.03)
    with pytest.raises(penumbra.Error, match="need an EXR"):
        penumbra.write(tmp_path / "b.png", img, metadata={"a": "b"})
    with pytest.raises(penumbra.Error):
        penumbra.read(tmp_path / "missing.exr")


def _tev_server():
    """A loopback server speaking tev's protocol: returns its port and a
    function that waits for the client to close and returns the packets
    (type, payload bytes)."""
    import socket
    import struct

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    got = []

    def serve():
        conn, _ = srv.accept()
        data = b""
        while True:
            chunk = conn.recv(1 << 16)
            if not chunk:
                break
            data += chunk
        conn.close()
        at = 0
        while at < len(data):
            (n,) = struct.unpack_from("<I", data, at)
            got.append((data[at + 4], data[at + 5 : at + n]))
            at += n

    t = threading.Thread(target=serve)
    t.start()

    def finish():
        t.join(30)
        srv.close()
        return got

    return srv.getsockname()[1], finish


def test_display_server_streams_the_image_to_tev(cbox):
    import struct

    port, finish = _tev_server()
    scene = penumbra.load_file(cbox, res=24)
    img = penumbra.render(scene, spp=4, progress=False, display_server=f"127.0.0.1:{port}")
    packets = finish()
    kinds = [k for k, _ in packets]
    # Create, then one update tile per pass (1, 1, 2 spp).
    assert kinds == [4, 6, 6, 6], kinds
    last = packets[-1][1]
    # grab focus, "penumbra\0", 3 channels "R\0G\0B\0", x y w h, 3 offsets, 3 strides.
    head = 1 + 9 + 4 + 6
    x, y, w, h = struct.unpack_from("<4i", last, head)
    assert (x, y, w, h) == (0, 0, 24, 24)
    data = np.frombuffer(last[head + 16 + 48 :], dtype="<f4").reshape(24, 24, 3)
    assert np.array_equal(bits(data), bits(img))
    with pytest.raises(Exception, match="HOST:PORT"):
        penumbra.render(scene, spp=1, progress=False, display_server="nowhere")


MESH_SCENE = """<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 1.5, 4" target="0, 0.3, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/></film>
  </sensor>
  <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.2, 0.1"/></bsdf>
  <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
  <shape type="sphere"><point name="center" value="0, 0.5, 0"/><float name="radius" value="0.5"/></shape>
  {extra}
</scene>
"""


def _tetra_mesh():
    """A pyramid over a floor quad, with per-vertex uvs and colours."""
    p = np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2], [0, 1.5, -1.2]], dtype=np.float32)
    f = np.array([[0, 2, 1], [0, 3, 2], [0, 1, 4], [1, 2, 4]], dtype=np.int32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], dtype=np.float32)
    return p, f, uv


def _write_ply(path, p, f, uv):
    lines = ["ply", "format ascii 1.0", f"element vertex {len(p)}", "property float x", "property float y",
             "property float z", "property float u", "property float v", f"element face {len(f)}",
             "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(repr(float(x)) for x in (*a, *b)) for a, b in zip(p, uv)]
    lines += ["3 " + " ".join(str(int(i)) for i in t) for t in f]
    path.write_text("\n".join(lines) + "\n")


def test_add_mesh_is_bitwise_the_same_mesh_from_a_ply_file(tmp_path):
    """A mesh given as numpy arrays goes through the same scene builder as a
    PLY file's: with the same bsdf, emission and placement, the images are
    bitwise equal (the mesh is the file's last shape in both)."""
    p, f, uv = _tetra_mesh()
    _write_ply(tmp_path / "m.ply", p, f, uv)
    m = np.array([[1, 0, 0, 0.1], [0, 1, 0, -0.2], [0, 0, 1, 0.3], [0, 0, 0, 1]])
    mat = " ".join(repr(float(x)) for x in m.reshape(-1))
    ply = (f'<shape type="ply"><string name="filename" value="m.ply"/><ref id="red"/>'
           f'<transform name="to_world"><matrix value="{mat}"/></transform>'
           f'<emitter type="area"><rgb name="radiance" value="0.5, 1, 2"/></emitter></shape>')
    a = penumbra.load_string(MESH_SCENE.format(extra=ply), base_dir=tmp_path)
    b = penumbra.load_string(MESH_SCENE.format(extra=""), base_dir=tmp_path)
    b.add_mesh(p, f, uvs=uv, bsdf="red", emission=[0.5, 1, 2], to_world=m)
    assert "2 lights" in repr(b) and "2 shapes" in repr(b), repr(b)
    ia = penumbra.render(a, progress=False)
    ib = penumbra.render(b, progress=False)
    assert np.array_equal(bits(ia), bits(ib))
    # Without the emission, another image: the comparison can fail.
    c = penumbra.load_string(MESH_SCENE.format(extra=""), base_dir=tmp_path)
    c.add_mesh(p, f, uvs=uv, bsdf="red", to_world=m)
    assert not np.array_equal(bits(penumbra.render(c, progress=False)), bits(ia))


def test_add_mesh_refuses_bad_arrays():
    p, f, _ = _tetra_mesh()
    s = penumbra.load_string(MESH_SCENE.format(extra=""))
    with pytest.raises(ValueError, match="add_mesh #0: indices: triangle 1 has vertex index 7"):
        s.add_mesh(p, np.array([[0, 1, 2], [0, 7, 1]]))
    with pytest.raises(ValueError, match=r"positions: shape \(5, 2\)"):
        s.add_mesh(p[:, :2], f)
    with pytest.raises(ValueError, match="indices: a 2D array of integer numbers"):
        s.add_mesh(p, f.astype(np.float64))
    with pytest.raises(ValueError, match="positions: row 4 holds NaN"):
        s.add_mesh(np.vstack([p[:4], [[np.nan, 0, 0]]]), f)
    with pytest.raises(ValueError, match="uvs: 3 rows for 5 vertices"):
        s.add_mesh(p, f, uvs=np.zeros((3, 2)))
    with pytest.raises(penumbra.Error, match='no top-level <bsdf id="blue">'):
        s.add_mesh(p, f, bsdf="blue")
    # A failed add leaves the scene as it was.
    assert "1 shapes" in repr(s), repr(s)
    s.add_mesh(p, f)
    assert "2 shapes" in repr(s), repr(s)


IMAGE_SCENE = """<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0, 0.6, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
    <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/></film>
  </sensor>
  <emitter type="envmap" id="env">{env}</emitter>
  <texture type="bitmap" id="tex">{tex}</texture>
  <shape type="rectangle"><bsdf type="diffuse"><ref name="reflectance" id="tex"/></bsdf></shape>
</scene>
"""


def _images(tmp_path):
    """Two small linear images written to EXR: a texture and an environment."""
    y, x = np.mgrid[0:12, 0:16]
    tex = np.stack([x / 15.0, y / 11.0, 0.25 + 0.5 * ((x + y) % 2)], axis=2).astype(np.float32)
    env = np.stack([1 + 0 * x, 0.5 + y / 11.0, 2.0 * (x < 4)], axis=2).astype(np.float32)
    penumbra.write(tmp_path / "tex.exr", tex)
    penumbra.write(tmp_path / "env.exr", env)
    return tex, env


def _files(tex="tex.exr", env="env.exr"):
    f = '<string name="filename" value="{}"/>'
    return IMAGE_SCENE.format(tex=f.format(tex), env=f.format(env))


def test_numpy_images_render_as_the_same_images_from_files(tmp_path):
    """A bitmap texture's and an envmap's `data` set from numpy render
    bitwise as the same pixels read from EXR files: through `set` on a
    scene read from files, and through `load_dict`."""
    tex, env = _images(tmp_path)
    ref = penumbra.render(penumbra.load_string(_files(), base_dir=tmp_path), progress=False)
    # The file's image replaced by other pixels: the image changes, and
    # equals the render of those pixels written to files.
    s = penumbra.load_string(_files(), base_dir=tmp_path)
    s.set("tex.data", tex[::-1] * 0.5)
    s.set("env.data", env[:, ::-1])
    other = penumbra.render(s, progress=False)
    assert not np.array_equal(bits(other), bits(ref))
    penumbra.write(tmp_path / "tex2.exr", tex[::-1] * 0.5)
    penumbra.write(tmp_path / "env2.exr", env[:, ::-1])
    from_files = penumbra.load_string(_files("tex2.exr", "env2.exr"), base_dir=tmp_path)
    assert np.array_equal(bits(other), bits(penumbra.render(from_files, progress=False)))
    assert np.array_equal(s.get("tex.data"), tex[::-1] * 0.5)
    # load_dict: arrays instead of file names, also for a nested texture.
    d = {
        "type": "scene",
        "sensor": {
            "type": "perspective", "fov": 50.0,
            "to_world": np.array(penumbra.load_string(_files(), base_dir=tmp_path).camera_to_world),
            "sampler": {"type": "independent", "sample_count": 8},
            "film": {"type": "hdrfilm", "width": 40, "height": 30},
        },
        "env": {"type": "envmap", "data": env},
        "plane": {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": {"type": "bitmap", "data": tex}}},
    }
    assert np.array_equal(bits(penumbra.render(penumbra.load_dict(d), progress=False)), bits(ref))


def test_numpy_images_are_checked(tmp_path):
    _images(tmp_path)
    s = penumbra.load_string(_files(), base_dir=tmp_path)
    bad = np.ones((4, 5, 3), dtype=np.float32)
    bad[2, 3, 1] = np.nan
    with pytest.raises(ValueError, match=r"tex.data: pixel \(row 2, column 3\) is NaN"):
        s.set("tex.data", bad)
    with pytest.raises(ValueError, match=r"an \(H, W, 3\) or \(H, W\) array, not \[4, 5, 2\]"):
        s.set("tex.data", np.ones((4, 5, 2)))
    # `data` on an object that reads no image is an unused parameter.
    with pytest.raises(penumbra.Error, match="data"):
        s.set("sensor.data", np.ones((4, 5)))
    # Grey arrays are broadcast to RGB.
    s.set("tex.data", np.full((4, 5), 0.5))
    assert s.get("tex.data").shape == (4, 5, 3)


def test_pbrt_and_gltf_files_render_as_the_command_line_does(cli, tmp_path):
    """`load_file` chooses the format by extension, as `penumbra render`."""
    for scene in [ROOT / "tests" / "scenes" / "gltf" / "boxes.gltf", PBRT_SCENE]:
        out = tmp_path / (scene.stem + ".exr")
        run_cli(cli, scene, "-o", out, "--spp", 4)
        s = penumbra.load_file(scene)
        assert "Scene(" in repr(s)
        img = penumbra.render(s, spp=4, progress=False)
        assert np.array_equal(bits(img), bits(penumbra.read(out)))
        with pytest.raises(penumbra.Error, match="Mitsuba XML scenes only"):
            s.set("x.y", 1.0)
        with pytest.raises(ValueError, match="Mitsuba XML scenes only"):
            s.add_mesh(*_tetra_mesh()[:2])
