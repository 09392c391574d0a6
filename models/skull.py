"""The skull phantom: an implicit union of ellipsoids, capsules and tubes, meshed in code.

Model frame (the phantom's own frame): x anterior (towards the face), y to the phantom's left,
z superior; origin near the centre of the cranial vault. The shape is designed in millimetres
and returned in metres. It has cranial vault, brow ridges, orbits, nasal aperture, zygomatic
arches, maxilla and mandible; it is mirror symmetric in y and has no rotational symmetry
(face versus occiput, vault versus jaw). A seed varies its proportions by a few percent.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from models.implicit import (
    capsule,
    ellipsoid,
    mesh_implicit,
    smooth_intersect,
    smooth_subtract,
    smooth_union,
    tube,
)
from models.mesh import TriangleMesh, component_labels
from models.model_errors import ModelError, ModelParameterError
from models.targets import BurrHole

MM = 1e-3
_LOWER_MM = np.array([-110.0, -85.0, -120.0])
_UPPER_MM = np.array([105.0, 85.0, 92.0])
# Tubes and capsules are evaluated as min(distance, _CAP): a blend (at most 10 mm) or the
# meshing band (12 mm) never looks that far, so the surface is the same and the field is cheaper.
_CAP = 30.0


@dataclass(frozen=True)
class SkullShape:
    """Proportions of the phantom (dimensionless scale factors about 1)."""

    vault: float = 1.0
    face: float = 1.0
    orbit: float = 1.0
    brow: float = 1.0
    arch: float = 1.0
    jaw: float = 1.0

    @classmethod
    def from_seed(cls, seed: int) -> SkullShape:
        """Proportions drawn uniformly within +-2 % (+-8 % for the small features)."""
        rng = np.random.default_rng(seed)
        vault, face = (float(x) for x in 1.0 + rng.uniform(-0.02, 0.02, size=2))
        orbit, brow, arch, jaw = (float(x) for x in 1.0 + rng.uniform(-0.08, 0.08, size=4))
        return cls(vault, face, orbit, brow, arch, jaw)


def _mirror(p: np.ndarray) -> np.ndarray:
    """Points folded onto the phantom's left half (y >= 0): left-right mirror symmetry."""
    q = p.copy()
    q[:, 1] = np.abs(q[:, 1])
    return q


def skull_sdf(p_mm: np.ndarray, shape: SkullShape) -> np.ndarray:
    """Signed distance-like field of the phantom at points `p_mm` (N, 3) [mm]; < 0 inside."""
    s = shape
    v = s.vault
    q = _mirror(p_mm)
    a = np.array

    # Cranial vault: a broad parieto-occipital ellipsoid and a narrower frontal one,
    # cut flat at the skull base, with an occipital protuberance at the back.
    vault = smooth_union(
        ellipsoid(q, a([-10.0, 0, 8]) * v, a([84.0, 70, 68]) * v),
        ellipsoid(q, a([25.0, 0, 5]) * v, a([62.0, 60, 62]) * v),
        10.0,
    )
    vault = smooth_intersect(vault, -(q[:, 2] + 40.0), 8.0)
    vault = smooth_union(vault, ellipsoid(q, a([-88.0, 0, -12]) * v, a([9.0, 16, 8])), 5.0)
    mastoid = ellipsoid(q, a([-18.0, 54, -44]) * v, a([9.0, 8, 12]))
    skull = smooth_union(vault, mastoid, 5.0)

    # Upper face, brow ridges and glabella, nasal bones, cheekbones.
    f = s.face
    upper_face = ellipsoid(q, a([55.0, 0, -25]) * f, a([33.0, 50, 38]) * f)
    skull = smooth_union(skull, upper_face, 8.0)
    brow = capsule(q, a([80.0, 8, 14]) * f, a([73.0, 47, 10]) * f, 7.0 * s.brow, _CAP)
    skull = smooth_union(skull, brow, 4.0)
    skull = smooth_union(skull, ellipsoid(q, a([84.0, 0, 12]) * f, a([6.0, 12, 7])), 3.0)
    skull = smooth_union(
        skull, capsule(q, a([81.0, 0, -2]) * f, a([88.0, 0, -22]) * f, 5.0, _CAP), 3.0
    )
    cheek = ellipsoid(q, a([66.0, 46, -32]) * f, a([14.0, 12, 15]))
    skull = smooth_union(skull, cheek, 5.0)

    # Zygomatic arches: from the cheekbone back to the temporal bone in front of the ear,
    # standing off the side of the vault (the temporal fossa lies behind them).
    r_arch = 5.0 * s.arch
    arch_path = a([[62.0, 54, -32], [30, 66, -30], [0, 68, -30], [-12, 62, -32], [-12, 50, -32]])
    skull = smooth_union(skull, tube(q, arch_path * [f, 1, 1], np.full(5, r_arch), _CAP), 3.0)

    # Maxilla with its alveolar (dental) arch.
    skull = smooth_union(skull, ellipsoid(q, a([58.0, 0, -58]) * f, a([27.0, 32, 14]) * f), 6.0)
    t = np.linspace(0.0, 1.0, 9)
    dental = np.column_stack([(80.0 - 40.0 * t**2) * f, 27.0 * t * f, np.full_like(t, -68.0)])
    skull = smooth_union(skull, tube(q, dental, np.full(len(t), 7.0), _CAP), 4.0)

    # Orbits and nasal aperture carved out of the face.
    o = s.orbit
    skull = smooth_subtract(
        skull, ellipsoid(q, a([90.0, 32, -8]) * [f, f, 1], a([32.0, 18, 16]) * o), 2.0
    )
    skull = smooth_subtract(skull, ellipsoid(q, a([92.0, 0, -38]) * f, a([26.0, 11, 16])), 2.0)

    # Mandible: body (two tubes along a U: alveolar edge and base), chin, ramus, coronoid
    # process and condyle, which rests against the skull base; teeth closed on the maxilla.
    j = s.jaw
    u = np.linspace(0.0, 1.0, 11)
    body_xy = np.column_stack([(76.0 - 62.0 * u**2) * f, 45.0 * u * j])
    for z, r in ((-78.0, 6.0), (-88.0, 7.0), (-98.0, 7.0)):
        path = np.column_stack([body_xy, np.full(len(u), z)])
        skull = smooth_union(skull, tube(q, path, np.full(len(u), r), _CAP), 4.0)
    skull = smooth_union(skull, ellipsoid(q, a([76.0 * f, 0, -100]), a([8.0, 14, 8])), 4.0)
    jaw_y = 45.0 * j
    ramus = [
        (a([14.0 * f, jaw_y, -100]), a([-4.0, jaw_y + 6, -42]), 6.0),
        (a([8.0 * f, jaw_y + 2, -88]), a([8.0, jaw_y + 4, -50]), 6.0),
        (a([20.0 * f, jaw_y, -78]), a([22.0, jaw_y + 1, -44]), 5.0),
    ]
    for p0, p1, r in ramus:
        skull = smooth_union(skull, capsule(q, p0, p1, r, _CAP), 4.0)
    condyle = ellipsoid(q, a([-4.0, jaw_y + 7, -38]), a([6.0, 10, 6]))
    return smooth_union(skull, condyle, 4.0)


def _ray_hits(
    vertices: np.ndarray, faces: np.ndarray, origin: np.ndarray, direction: np.ndarray
) -> np.ndarray:
    """Distances t >= 0 along the ray where it crosses the mesh (Moller-Trumbore, all faces)."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    e1, e2 = b - a, c - a
    h = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, h)
    ok = np.abs(det) > 1e-18
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = origin - a
    u = inv * np.einsum("ij,ij->i", s, h)
    qv = np.cross(s, e1)
    v = inv * (qv @ direction)
    t = inv * np.einsum("ij,ij->i", e2, qv)
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0)
    return t[hit]


def _burr_holes(mesh: trimesh.Trimesh) -> tuple[BurrHole, ...]:
    """Burr holes where rays from the vault centre leave the skull; trajectories aim at deep
    targets near the midline (frontal horns, thalamus), 45-55 mm deep."""
    p_centre = np.array([0.0, 0.0, 10.0]) * MM
    plans = [  # name, direction from the centre, deep-target aim point [mm], depth [mm]
        ("kocher_right", (0.45, -0.3, 0.84), (15.0, -12.0, 5.0), 50.0),
        ("kocher_left", (0.45, 0.3, 0.84), (15.0, 12.0, 5.0), 50.0),
        ("parietal_right", (-0.45, -0.45, 0.77), (-5.0, -15.0, 0.0), 45.0),
        ("occipital_left", (-0.8, 0.3, 0.5), (-20.0, 12.0, 0.0), 55.0),
    ]
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    holes = []
    for name, direction, aim_mm, depth_mm in plans:
        d = np.array(direction) / np.linalg.norm(direction)
        t = _ray_hits(vertices, faces, p_centre, d)
        if len(t) == 0:
            raise ModelError(f"burr hole {name}: the ray from the vault centre misses the skull")
        p_entry = p_centre + t.max() * d
        aim = np.array(aim_mm) * MM - p_entry
        holes.append(BurrHole(name, p_entry, aim / np.linalg.norm(aim), depth_mm * MM))
    return tuple(holes)


@dataclass(frozen=True, eq=False)
class SkullPhantom:
    """The generated phantom: `mesh` in metres (model frame) and its burr holes."""

    mesh: TriangleMesh
    burr_holes: tuple[BurrHole, ...]
    seed: int
    shape: SkullShape


def make_skull(
    seed: int = 0, spacing_mm: float = 1.7, smoothing_iterations: int = 10
) -> SkullPhantom:
    """Generate the skull phantom, deterministic from `seed`.

    `spacing_mm` is the marching-cubes grid step [mm] (1.7 mm gives about 110k triangles);
    the mesh is Taubin-smoothed (`smoothing_iterations`, no shrinkage) and is one watertight
    component. Takes about a second.
    """
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ModelParameterError(f"seed must be a non-negative integer, got {seed!r}")
    if not 0.5 <= spacing_mm <= 5.0:
        raise ModelParameterError(f"spacing_mm must lie in [0.5, 5] mm, got {spacing_mm}")
    shape = SkullShape.from_seed(int(seed))
    mesh = mesh_implicit(lambda p: skull_sdf(p, shape), _LOWER_MM, _UPPER_MM, spacing_mm)
    if smoothing_iterations > 0:
        trimesh.smoothing.filter_taubin(mesh, lamb=0.5, nu=0.53, iterations=smoothing_iterations)
    labels = component_labels(mesh)
    if labels.max() > 0:  # keep the skull, drop specks of the level set (none expected)
        largest = np.argmax(np.bincount(labels))
        mesh.update_faces(labels == largest)
        mesh.remove_unreferenced_vertices()
    if not mesh.is_watertight:
        raise ModelError("the generated skull is not watertight (try another grid spacing)")
    mesh.apply_scale(MM)
    return SkullPhantom(TriangleMesh.from_trimesh(mesh), _burr_holes(mesh), int(seed), shape)
