"""A parameter sweep from Python: the Cornell box's left wall from red to
blue, rendered into numpy arrays and laid out as a matplotlib figure.

    pip install . matplotlib        # from the repository root
    python examples/python/sweep.py [out.png]

Each step changes one reflectance by id and renders again; the geometry and
its BVH are built once (scene.geometry_builds stays the same).
"""

import pathlib
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import penumbra

ROOT = pathlib.Path(__file__).resolve().parents[2]
out = sys.argv[1] if len(sys.argv) > 1 else "sweep.png"

scene = penumbra.load_file(ROOT / "scenes" / "cornell-box.xml", res=160)
red, blue = np.array([0.63, 0.065, 0.05]), np.array([0.05, 0.1, 0.63])
steps = np.linspace(0.0, 1.0, 5)
fig, axes = plt.subplots(1, len(steps), figsize=(3 * len(steps), 3.3))
for ax, t in zip(axes, steps):
    colour = (1 - t) * red + t * blue
    scene.set("red.reflectance", colour.tolist())
    start = time.perf_counter()
    img = penumbra.render(scene, spp=64, progress=False)
    seconds = time.perf_counter() - start
    srgb = np.where(img <= 0.0031308, 12.92 * img, 1.055 * np.power(np.clip(img, 0.0031308, None), 1 / 2.4) - 0.055)
    ax.imshow(np.clip(srgb, 0, 1))
    ax.set_title("wall = (%.2f, %.2f, %.2f)\n%.2f s" % (*colour, seconds), fontsize=9)
    ax.axis("off")
fig.suptitle("penumbra: one reflectance swept, geometry built once %s" % (scene.geometry_builds,), fontsize=10)
fig.tight_layout(rect=(0, 0, 1, 0.92))
fig.savefig(out, dpi=80)
print("wrote", out)
