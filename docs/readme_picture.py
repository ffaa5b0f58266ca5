"""Renders docs/lod.png for the README: one model at three levels of detail taken from its vertex tree.

    cargo run --release -- build assets/cessna.obj -o out/cessna.vtree
    for r in 1 0.1 0.02; do cargo run --release -- extract out/cessna.vtree --ratio $r -o out/cessna-$r.obj; done
    python3 docs/readme_picture.py out/cessna-1.obj out/cessna-0.1.obj out/cessna-0.02.obj

A stand-in until the wgpu renderer exists; needs matplotlib.
"""
import sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from mpl_toolkits.mplot3d.art3d import Poly3DCollection


def load(path):
    v, f = [], []
    for line in open(path):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            v.append([float(x) for x in t[1:4]])
        elif t[0] == "f":
            f.append([int(x.split("/")[0]) - 1 for x in t[1:4]])
    return np.array(v), np.array(f)


paths = sys.argv[1:]
fig = plt.figure(figsize=(4 * len(paths), 3.6), dpi=110)
light = np.array([0.4, 0.3, 1.0])
light /= np.linalg.norm(light)
for i, path in enumerate(paths):
    v, f = load(path)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    shade = 0.25 + 0.75 * np.abs(n @ light)
    ax = fig.add_subplot(1, len(paths), i + 1, projection="3d")
    colors = np.stack([0.55 * shade, 0.7 * shade, 0.9 * shade, np.ones_like(shade)], axis=1)
    ax.add_collection3d(Poly3DCollection(tri, facecolors=colors, edgecolors=(0, 0, 0, 0.25), linewidths=0.2))
    lo, hi = v.min(0), v.max(0)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.view_init(elev=25, azim=-60)
    ax.set_axis_off()
    ax.set_title(f"{len(f)} triangles", fontsize=11)
plt.tight_layout()
plt.savefig("docs/lod.png")
