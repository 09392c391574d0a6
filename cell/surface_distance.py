"""Distances from the moving side's geoms to an object's real surface, where its convex proxy
would not do.

MuJoCo collides a concave object through convex pieces (models.convex), which stand proud of
a rough surface (a CT-derived bone) by millimetres; a tool that clears the bone would be
judged to touch it. Near such an object the virtual cell asks this module instead: the signed
distance from the geom to the object's triangle mesh (libigl's AABB tree for the closest
point, the sign from the angle-weighted pseudonormal of the closest feature, as libigl's
`signed_distance` does it, negative inside).

A geom stands for points in its own frame: a sphere for its centre and a capsule for its
axis (sampled every `AXIS_STEP_M`), each less its radius; any other geom (box, cylinder,
ellipsoid, mesh) for points on its surface about `SURFACE_STEP_M` apart (wider on a geom
larger than `MAX_SURFACE_POINTS` such points would cover). Their smallest
distance overstates the geom's own by at most the samples' `deviation_m` (half the axis step;
the surface samples' covering radius, measured when they are made), which is subtracted: the
distance reported is never larger than the true one, and at most `deviation_m` smaller.
Surface samples are searched coarse to fine: clusters about `CLUSTER_M` across, the fine
points only of clusters that may hold the smallest distance (the distance is 1-Lipschitz).
"""

from __future__ import annotations

from dataclasses import dataclass

import igl
import mujoco
import numpy as np
import trimesh
from scipy.spatial import cKDTree

#: Spacing of a capsule's axis samples [m] (the distance is overstated by half of it at most).
AXIS_STEP_M = 5e-5
#: Spacing of the surface samples of other geoms [m], and at most this many samples (a large
#: geom gets a wider spacing, and states its larger deviation).
SURFACE_STEP_M = 1e-3
MAX_SURFACE_POINTS = 40_000
#: Size of the clusters of surface samples searched first [m].
CLUSTER_M = 6e-3


@dataclass(frozen=True, eq=False)
class GeomPoints:
    """Points that stand for one geom, in the geom's frame: `points` (N, 3) [m] with
    `cluster` (N,) their cluster, `centres` (C, 3) the clusters' centres and `reach_m` (C,)
    how far their points lie from them [m]; `radius_m` subtracted from the points' distance
    (a sphere's or capsule's radius, else 0); `deviation_m` by how much the points' smallest
    distance may overstate the geom's own [m]."""

    points: np.ndarray
    cluster: np.ndarray
    centres: np.ndarray
    reach_m: np.ndarray
    radius_m: float
    deviation_m: float


def _clustered(
    points: np.ndarray, radius_m: float, deviation_m: float, step_m: float = 0.0
) -> GeomPoints:
    """`points` grouped into clusters about CLUSTER_M (or 6 `step_m`) across (a grid of that
    pitch)."""
    key = np.floor(points / max(CLUSTER_M, 6.0 * step_m)).astype(np.int64)
    _, cluster = np.unique(key, axis=0, return_inverse=True)
    cluster = cluster.reshape(-1)
    count = int(cluster.max()) + 1
    centres = np.zeros((count, 3))
    np.add.at(centres, cluster, points)
    centres /= np.bincount(cluster, minlength=count)[:, None]
    reach = np.zeros(count)
    np.maximum.at(reach, cluster, np.linalg.norm(points - centres[cluster], axis=1))
    return GeomPoints(points, cluster, centres, reach, radius_m, deviation_m)


def _box_points(half: np.ndarray, step: float) -> np.ndarray:
    """Grids on the six faces of a box of half sizes `half` (3,), at most `step` apart."""
    axes = [np.linspace(-h, h, max(2, int(np.ceil(2 * h / step)) + 1)) for h in half]
    faces = []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        gb, gc = np.meshgrid(axes[b], axes[c], indexing="ij")
        for sign in (-1.0, 1.0):
            face = np.zeros((gb.size, 3))
            face[:, a], face[:, b], face[:, c] = sign * half[a], gb.ravel(), gc.ravel()
            faces.append(face)
    return np.unique(np.vstack(faces), axis=0)


def _cylinder_points(radius: float, half: float, step: float) -> np.ndarray:
    """Rings on the side and the two caps of a cylinder along z, at most `step` apart."""
    n_side = max(8, int(np.ceil(2 * np.pi * radius / step)))
    theta = np.linspace(0.0, 2 * np.pi, n_side, endpoint=False)
    z = np.linspace(-half, half, max(2, int(np.ceil(2 * half / step)) + 1))
    tt, zz = np.meshgrid(theta, z, indexing="ij")
    parts = [np.stack([radius * np.cos(tt).ravel(), radius * np.sin(tt).ravel(), zz.ravel()], 1)]
    for rho in np.linspace(0.0, radius, max(2, int(np.ceil(radius / step)) + 1))[:-1]:
        n = max(1, int(np.ceil(2 * np.pi * rho / step)))
        a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        for zc in (-half, half):
            parts.append(np.stack([rho * np.cos(a), rho * np.sin(a), np.full(n, zc)], 1))
    return np.vstack(parts)


def _surface(model: mujoco.MjModel, geom: int) -> trimesh.Trimesh | None:
    """The surface of a box, cylinder, ellipsoid or mesh geom as triangles in its frame (to
    probe the samples' covering radius; a mesh's or an ellipsoid's to sample)."""
    kind, size = int(model.geom_type[geom]), np.asarray(model.geom_size[geom], dtype=float)
    T = mujoco.mjtGeom
    if kind == T.mjGEOM_BOX:
        return trimesh.creation.box(extents=2.0 * size)
    if kind == T.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=512)
    if kind == T.mjGEOM_ELLIPSOID:
        sphere = trimesh.creation.icosphere(subdivisions=5)
        return trimesh.Trimesh(sphere.vertices * size, sphere.faces, process=False)
    if kind == T.mjGEOM_MESH:
        mesh = int(model.geom_dataid[geom])
        v0, nv = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        f0, nf = int(model.mesh_faceadr[mesh]), int(model.mesh_facenum[mesh])
        vertices = np.asarray(model.mesh_vert[v0 : v0 + nv], dtype=float)
        return trimesh.Trimesh(vertices, np.asarray(model.mesh_face[f0 : f0 + nf]), process=False)
    return None


def geom_points(model: mujoco.MjModel, geom: int) -> GeomPoints | None:
    """The points that stand for geom `geom` of `model` (see the module's docstring); None
    for a geom that has no closed extent (a plane, a height field)."""
    kind, size = int(model.geom_type[geom]), np.asarray(model.geom_size[geom], dtype=float)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return _clustered(np.zeros((1, 3)), float(size[0]), 0.0)
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        half = float(size[1])
        z = np.linspace(-half, half, max(2, int(np.ceil(2 * half / AXIS_STEP_M)) + 1))
        axis = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
        return _clustered(axis, float(size[0]), 0.5 * float(z[1] - z[0]))
    surface = _surface(model, geom)
    if surface is None:
        return None
    step = max(SURFACE_STEP_M, float(np.sqrt(surface.area / MAX_SURFACE_POINTS)))
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        points = _box_points(size, step)
    elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        points = _cylinder_points(float(size[0]), float(size[1]), step)
    else:
        count = int(min(MAX_SURFACE_POINTS, np.ceil(2.0 * surface.area / step**2)))
        sampled, _ = trimesh.sample.sample_surface(surface, count, seed=0)
        points = np.vstack([sampled, surface.vertices])
    # The covering radius, measured: how far any point of the surface lies from a sample.
    probe, _ = trimesh.sample.sample_surface(surface, min(4 * len(points), 200_000), seed=1)
    deviation = float(cKDTree(points).query(probe)[0].max())
    return _clustered(np.asarray(points, dtype=float), 0.0, deviation, step)


class SurfaceDistance:
    """Signed distances to a closed triangle mesh `vertices` (N, 3) [m], `faces` (M, 3) in its
    object frame (negative inside)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.V = np.ascontiguousarray(vertices, dtype=float)
        self.F = np.ascontiguousarray(faces, dtype=np.int64)
        self.tree = igl.AABB()
        self.tree.init(self.V, self.F)
        self.face_normal = igl.per_face_normals(self.V, self.F, np.zeros(3))
        self.vertex_normal = igl.per_vertex_normals(
            self.V, self.F, igl.PER_VERTEX_NORMALS_WEIGHTING_TYPE_ANGLE
        )
        self.edge_normal, _E, self.edge_of = igl.per_edge_normals(
            self.V, self.F, igl.PER_EDGE_NORMALS_WEIGHTING_TYPE_UNIFORM
        )

    def signed(self, p_object: np.ndarray) -> np.ndarray:
        """(N,) signed distances [m] of points (N, 3) in the object frame."""
        p = np.ascontiguousarray(np.atleast_2d(p_object), dtype=float)
        d2, face, closest = self.tree.squared_distance(self.V, self.F, p)
        corners = self.V[self.F[face]]  # (N, 3, 3)
        a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
        bary = igl.barycentric_coordinates(np.ascontiguousarray(closest), a, b, c)
        on = np.asarray(bary) > 1e-6  # which corners' weights are not zero
        normal = self.face_normal[face].copy()
        edge = on.sum(axis=1) == 2  # on an edge: the one opposite the corner with no weight
        if edge.any():
            opposite = np.argmin(bary[edge], axis=1)
            normal[edge] = self.edge_normal[self.edge_of[face[edge] + opposite * len(self.F)]]
        corner = on.sum(axis=1) <= 1  # at a corner: its vertex
        if corner.any():
            which = np.argmax(bary[corner], axis=1)
            normal[corner] = self.vertex_normal[self.F[face[corner], which]]
        inside = np.einsum("ij,ij->i", p - closest, normal) < 0.0
        return np.where(inside, -1.0, 1.0) * np.sqrt(np.maximum(d2, 0.0))

    def geom_distance(self, points: GeomPoints, T_object_geom: np.ndarray) -> float:
        """The geom's signed distance [m] to the surface, the geom at T_object_geom (4, 4):
        the smallest over its points less their radius and their deviation (never more than
        the true distance)."""
        R, t = T_object_geom[:3, :3], T_object_geom[:3, 3]
        coarse = self.signed(points.centres @ R.T + t)
        # A cluster's points lie within its reach of its centre, and the distance changes no
        # faster than the point moves: the smallest is at most `upper`, and only clusters
        # whose least possible distance is below it may hold it.
        upper = float((coarse + points.reach_m).min())
        wanted = np.flatnonzero(coarse - points.reach_m <= upper)
        fine = points.points[np.isin(points.cluster, wanted)]
        d = float(self.signed(fine @ R.T + t).min())
        return d - points.radius_m - points.deviation_m
