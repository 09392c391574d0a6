"""Writes the PCD files of this folder with Open3D (the reference writer, `pip install
open3d`; it needs the system library libusb-1.0-0): 500 points of a seeded ellipsoid patch, in
metres, as DATA ascii, binary and binary_compressed, and the points themselves as points.npy.

Usage: python tests/data/pcd/make_pcd.py
"""

from pathlib import Path

import numpy as np
import open3d as o3d

here = Path(__file__).parent
rng = np.random.default_rng(0)
u, v = rng.uniform(0, np.pi, 500), rng.uniform(0, np.pi, 500)
points = np.stack([0.05 * np.cos(u) * np.sin(v), 0.03 * np.sin(u) * np.sin(v), 0.02 * np.cos(v)], 1)
np.save(here / "points.npy", points)
cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
for name, ascii_, compressed in (("ascii", True, False), ("binary", False, False),
                                 ("binary_compressed", False, True)):  # fmt: skip
    o3d.io.write_point_cloud(
        str(here / f"cloud_{name}.pcd"), cloud, write_ascii=ascii_, compressed=compressed
    )
