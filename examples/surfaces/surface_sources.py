"""
Implicit surfaces from samples, a mesh, coefficients and points
===============================================================

Four surfaces side by side, each drawn per pixel from its quadratic B-spline field
(``pv_cubemarch.add_surface``), marching only the cells the surface crosses:

- a sampled field (a CT-like volume of smooth blobs) with an isovalue;
- PyVista's shipped ``nut.ply`` mesh, by its signed distance on 48 cells along its longest
  side;
- raw coefficients: a torus-like field written down by hand, 12 + 2 per axis;
- a point cloud with outward normals (points on an ellipsoid), fitted by sparse least
  squares on 24 cells, coloured by its mean curvature.

The field object stays on ``actor.cubemarch.model``: it can be evaluated on the CPU and
saved.
"""

import tempfile
from pathlib import Path

import numpy as np
import pyvista as pv
from pyvista import examples

import pv_cubemarch
from pv_cubemarch import SplineField

pl = pv.Plotter(window_size=(1100, 360))

# 1. Samples and an isovalue: the inside is where the data exceed it.
x, y, z = np.mgrid[-1:1:40j, -1:1:40j, -1:1:40j]
blobs = sum(np.exp(-((x - a) ** 2 + (y - b) ** 2 + (z - c) ** 2) / 0.08)
            for a, b, c in [(-0.3, 0.0, 0.0), (0.35, 0.1, 0.0), (0.0, -0.2, 0.3)])
grid = pv.ImageData(dimensions=blobs.shape, spacing=(0.05, 0.05, 0.05), origin=(-4.0, -1, -1))
grid.point_data["density"] = blobs.ravel(order="F")
samples = pv_cubemarch.add_surface(pl, grid, isovalue=0.5, color="lightsalmon")

# 2. A closed mesh: its signed distance, positive inside.
nut = pv.read(Path(examples.__file__).parent / "nut.ply")
nut.translate(-np.array(nut.center), inplace=True)
nut.scale(1.6 / max(nut.bounds[1] - nut.bounds[0], 1e-9), inplace=True)
mesh = pv_cubemarch.add_surface(pl, nut, cells=48, color="lightsteelblue")

# 3. Raw coefficients: (n + 2) per axis, c[i] peaking at the centre of cell i - 1.
n = 12
i = np.arange(-1, n + 1) + 0.5
cx, cy, cz = np.meshgrid(i - n / 2, i - n / 2, i - n / 2, indexing="ij")
ring = (np.hypot(cx, cy) - 3.5) ** 2 + cz ** 2
coefficients = 2.0 ** 2 - ring                       # positive inside the ring
placement = np.diag([0.14, 0.14, 0.14, 1.0])
placement[:3, 3] = (2.2, -0.85, -0.85)
torus = pv_cubemarch.add_surface(pl, SplineField(coefficients, transform=placement),
                                 color="khaki", root="exact")

# 4. A point cloud with outward normals: the least-squares field through the points.
rng = np.random.default_rng(0)
directions = rng.normal(size=(3000, 3))
directions /= np.linalg.norm(directions, axis=1, keepdims=True)
axes = np.array([0.5, 0.7, 0.9])
points = directions * axes + (5.0, 0.0, 0.0)
normals = directions / axes                        # the ellipsoid's gradient direction
normals /= np.linalg.norm(normals, axis=1, keepdims=True)
cloud = pv_cubemarch.add_surface(pl, (points, normals), cells=24, color_by="curvature",
                                 cmap="coolwarm")

pl.camera_position = [(0.0, -7.0, 3.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
pl.reset_camera()
pl.camera.zoom(1.7)
for name, actor in [("samples", samples), ("mesh", mesh), ("coefficients", torus),
                    ("point cloud", cloud)]:
    binding = actor.cubemarch
    print(f"{name}: {binding.model.dimensions} cells, {len(binding.cells)} active, "
          f"{binding.nbytes / 1e3:.0f} kB on the GPU (dense: {binding.dense_bytes / 1e3:.0f} kB)")
field = samples.cubemarch.model
print("field at the first blob's centre:", float(field(np.array([[-3.3, 0.0, 0.0]]))[0]))
with tempfile.TemporaryDirectory() as folder:
    field.save(Path(folder) / "blobs.npz")
    print("saved and read back:", pv_cubemarch.SplineField.load(Path(folder) / "blobs.npz"))
pl.show()
