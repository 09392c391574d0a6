"""The model's own symmetries: rigid motions that map the model onto itself.

If a motion S maps the model onto itself, every pose S T fits any scan exactly as well as
T: no data, however dense or noise-free, can tell them apart, and a ratio of two equal
costs says nothing. The symmetries are therefore found once per model, by registering the
model to itself, and reported as what they are:
- a turn: a discrete rotation (a half turn that flips a part end for end, an n-fold turn);
- an axis: any turn about an axis (a surface of revolution, a faceted cylinder whose
  facets the data cannot resolve);
- a sphere: any rotation about a centre.

A target that a symmetry leaves in place (on a cylinder's axis, at a sphere's centre) is
located as well as the pose is constrained; a target it moves is not located at all.

The self-registration starts from near-uniform rotations about the centroid plus the turns
that the principal axes of the surface suggest (half turns, and n-fold turns about an axis
whose two other moments are equal); each start runs a few ICP iterations together with the
others, and a motion is a symmetry if it moves the surface sample onto the model within the
tolerance: what the data can resolve.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

from registration.kernels import Tukey
from registration.rigid import Array, make_T, make_T_batch, transform_points
from registration.search import batched_icp, closest_pairs, distinct, lookup_pairs, subsample
from registration.shapes.base import Shape
from registration.starts import super_fibonacci_rotations

SymmetryKind = Literal["turn", "axis", "sphere"]

#: Turns about an axis tried to decide that every turn about it fits: small, large, and
#: incommensurate with every n-fold symmetry of small n.
_PROBE_ANGLES = np.radians([13.1, 0.7, 47.3, 2.9])


@dataclass(frozen=True)
class Symmetry:
    """A rigid motion of the model onto itself, in the model frame.

    Attributes:
        kind: "turn" (a rotation by `angle`), "axis" (any rotation about the axis) or
            "sphere" (any rotation about `point`).
        axis: unit direction of the rotation axis (3,); zeros for a sphere.
        point: a point on the axis, or the sphere's centre (3,) [length units].
        angle: the turn's angle [rad] in (0, pi]; nan for an axis or a sphere.
        residual: RMS distance from the model of its surface moved by the motion (for an
            axis or a sphere, the largest over the probe turns) [length units].
    """

    kind: SymmetryKind
    axis: Array
    point: Array
    angle: float
    residual: float

    @property
    def name(self) -> str:
        """The symmetry in words, with its axis and point in the model frame."""
        a = ", ".join(f"{x:.3f}" for x in self.axis)
        p = ", ".join(f"{x:.4g}" for x in self.point)
        if self.kind == "sphere":
            return f"free rotation (any angle) about the centre ({p})"
        if self.kind == "axis":
            return f"free turn (any angle) about the axis ({a}) through ({p})"
        n = 2.0 * np.pi / self.angle
        if abs(n - round(n)) < 0.02:
            fold = "half turn" if round(n) == 2 else f"{round(n)}-fold turn"
        else:
            fold = "turn"
        return f"{fold} ({np.degrees(self.angle):.1f} deg) about the axis ({a}) through ({p})"

    def motion(self, angle: float | None = None) -> Array:
        """T_model_model (4, 4): the rotation about the axis through the point by `angle`
        (the turn's own angle by default)."""
        theta = self.angle if angle is None else angle
        if not np.isfinite(theta):
            raise ValueError(f"the {self.kind} symmetry needs an angle for its motion")
        R = Rotation.from_rotvec(self.axis * theta).as_matrix()
        return make_T(R, self.point - R @ self.point)

    def displacement(self, points: Array) -> Array:
        """How far the symmetry can move each point (K, 3): (K,) [length units].

        A turn moves a point to one place; an axis or a sphere moves it anywhere on a
        circle or a sphere, up to twice its distance from the axis or the centre.
        """
        x = np.atleast_2d(np.asarray(points, dtype=float))
        if self.kind == "turn":
            return np.linalg.norm(transform_points(self.motion(), x) - x, axis=1)
        offset = x - self.point
        if self.kind == "axis":
            offset = offset - np.outer(offset @ self.axis, self.axis)
        return 2.0 * np.linalg.norm(offset, axis=1)

    def closest_motion(self, M: Array) -> Array:
        """The motion of this symmetry nearest to M (4, 4): M itself if it is one."""
        if self.kind == "turn":
            return self.motion()
        R = M[:3, :3]
        if self.kind == "sphere":
            return make_T(R, self.point - R @ self.point)
        u = np.cross(self.axis, [1.0, 0.0, 0.0])
        if np.linalg.norm(u) < 0.1:
            u = np.cross(self.axis, [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        Ru = R @ u
        return self.motion(float(np.arctan2(self.axis @ np.cross(u, Ru), u @ Ru)))


def _screw(T: Array) -> tuple[Array, float, Array]:
    """Axis (3,), angle [rad] and a point on the axis (3,) of a rigid motion (4, 4)."""
    rotvec = Rotation.from_matrix(T[:3, :3]).as_rotvec()
    angle = float(np.linalg.norm(rotvec))
    axis = rotvec / angle if angle > 0 else np.array([0.0, 0.0, 1.0])
    # The point p with (I - R) p = t - (a . t) a, nearest the origin.
    t = T[:3, 3]
    point = np.linalg.lstsq(np.eye(3) - T[:3, :3], t - (axis @ t) * axis, rcond=None)[0]
    point -= (point @ axis) * axis
    return axis, angle, point


def _residual(shape: Shape, T: Array, points: Array, normals: Array | None) -> float:
    """RMS distance of the surface points (N, 3) moved by T from the model: along the
    model's normal where it has one (so that a point between two samples of a point model
    is not counted as off the surface), else to the nearest model point."""
    p = transform_points(T, points)
    c = shape.closest(p)
    if c.normals is None or normals is None:
        d = c.distances
    else:
        d = np.einsum("nd,nd->n", c.normals, p - c.points)
    return float(np.sqrt(np.mean(d**2)))


def symmetry_tolerance(shape: Shape, floor: float) -> float:
    """Largest residual [length units] of a motion that counts as a symmetry: the floor
    (what the data resolve), or half the point spacing of a point model without normals."""
    if shape.sample_normals is None:
        return max(floor, 0.5 * shape.resolution)
    return floor


def find_symmetries(shape: Shape, floor: float, seed: int = 0) -> tuple[Symmetry, ...]:
    """The model's symmetries within `floor` [length units], cached on the shape.

    Args:
        shape: the model.
        floor: the smallest surface deviation the data can resolve (the sensor noise, or
            the resolution floor); a motion that keeps the surface within it (RMS) is a
            symmetry.
        seed: seed of the surface subsample used.
    """
    cache = symmetry_cache(shape)
    key = (float(f"{floor:.6g}"), seed)
    if key not in cache:
        cache[key] = _find(shape, symmetry_tolerance(shape, floor), seed)
    return cache[key]


def symmetry_cache(shape: Shape) -> dict[tuple[float, int], tuple[Symmetry, ...]]:
    """The symmetries found so far on `shape`, by (floor to 6 significant digits, seed):
    what `find_symmetries` returns again, and what a prepared-model file stores
    (registration.prepared)."""
    cache: dict[tuple[float, int], tuple[Symmetry, ...]] = shape.__dict__.setdefault(
        "_symmetry_cache", {}
    )
    return cache


def _hint_rotations(samples: Array) -> Array:
    """Turns the principal axes of the surface suggest (R, 3, 3): half turns about each, and
    3-, 4-, 5-, 6- and 8-fold turns about each (an axis whose two other moments are equal
    may carry them)."""
    centred = samples - samples.mean(axis=0)
    _, vecs = np.linalg.eigh(centred.T @ centred)
    out = []
    for axis in vecs.T:
        for n in (2, 3, 4, 5, 6, 8):
            out.append(Rotation.from_rotvec(axis * 2.0 * np.pi / n).as_matrix())
    return np.array(out)


def _find(shape: Shape, tolerance: float, seed: int) -> tuple[Symmetry, ...]:
    rng = np.random.default_rng(seed)
    points = shape.samples[subsample(shape.samples, 600, rng)]
    normals = shape.sample_normals
    c = shape.centroid
    R = np.concatenate([super_fibonacci_rotations(192), _hint_rotations(shape.samples)])
    T = make_T_batch(R, c - R @ c)
    lookup = shape.sample_lookup
    coarse = points[:150]
    p = coarse @ T[:, :3, :3].transpose(0, 2, 1) + T[:, None, :3, 3]
    d, _ = lookup.query(p)
    cost = np.sqrt(np.mean(np.minimum(d, lookup.reach) ** 2, axis=1))
    angles = np.linalg.norm(Rotation.from_matrix(R).as_rotvec(), axis=1)
    order = [i for i in np.argsort(cost, kind="stable") if angles[i] > np.radians(3.0)]
    keep = np.array(order[:32], dtype=int)
    kernel = Tukey(min_scale=1e-4 * shape.extent)
    T_k, cost_k = batched_icp(coarse, T[keep], 6, 0.95, kernel, lookup_pairs(shape), lookup.reach)
    # Survivors: the turned surface back on the model to a small part of a lookup voxel (a
    # symmetry's point-to-plane cost is the sample's curvature error, a hundredth of a voxel
    # on a sphere; a different pose's is tenths of one) and not back at the identity;
    # refined against the surface sample.
    turned = np.linalg.norm(Rotation.from_matrix(T_k[:, :3, :3]).as_rotvec(), axis=1)
    close = np.flatnonzero((cost_k < max(0.05 * lookup.h, 3.0 * tolerance)) & (turned > 0.01))
    if len(close) == 0:
        return ()
    close = close[np.argsort(cost_k[close], kind="stable")]
    close = close[
        distinct(list(T_k[close]), np.arange(len(close)), coarse, 0.01 * shape.extent, 24)
    ]
    near = closest_pairs(lambda p: shape.near(p, lookup.reach), lookup.reach)
    T_k, _ = batched_icp(points[:200], T_k[close], 5, 0.95, kernel, near, lookup.reach)
    turns: list[Symmetry] = []
    for T_s in T_k:
        axis, angle, point = _screw(T_s)
        if angle < np.radians(1.0):
            continue  # back at the identity
        if abs(axis @ T_s[:3, 3]) > 10 * tolerance + 1e-3 * shape.extent:
            continue  # a screw along the axis: no symmetry of a bounded surface
        residual = _residual(shape, T_s, points, normals)
        if residual > tolerance:
            continue
        if any(
            np.linalg.norm(transform_points(s.motion(), points) - transform_points(T_s, points))
            < 0.01 * shape.extent
            for s in turns
        ):
            continue
        turns.append(Symmetry("turn", axis, point, angle, residual))
    return _continuous(shape, turns, points, normals, tolerance)


def _continuous(
    shape: Shape, turns: list[Symmetry], points: Array, normals: Array | None, tolerance: float
) -> tuple[Symmetry, ...]:
    """Turns whose axis carries every turn become one axis symmetry; two such axes, a
    sphere."""
    axes: list[Symmetry] = []
    for s in turns:
        if any(_same_axis(s, a, shape.extent) for a in axes):
            continue
        worst = 0.0
        for angle in _PROBE_ANGLES:  # the most telling first: most axes fail at once
            motion = Symmetry("turn", s.axis, s.point, angle, 0.0).motion()
            worst = max(worst, _residual(shape, motion, points[:200], normals))
            if worst > tolerance:
                break
        else:
            axes.append(Symmetry("axis", s.axis, s.point, float("nan"), worst))
            if len(axes) == 2:
                break
    if len(axes) >= 2:
        centre = _nearest_point_of_axes(axes)
        return (Symmetry("sphere", np.zeros(3), centre, float("nan"), axes[0].residual),)
    rest = [s for s in turns if not any(_same_axis(s, a, shape.extent) for a in axes)]
    if axes:
        # With every turn about the axis, the half turns about the axes across it are one
        # and the same symmetry up to such a turn: keep one.
        across = [s for s in rest if abs(s.axis @ axes[0].axis) < 1e-3]
        rest = [s for s in rest if abs(s.axis @ axes[0].axis) >= 1e-3] + across[:1]
    rest.sort(key=lambda s: (s.angle, tuple(np.round(s.axis, 6))))
    return (*axes, *rest)


def _same_axis(a: Symmetry, b: Symmetry, extent: float) -> bool:
    """True if two symmetries turn about the same line (either direction)."""
    if abs(abs(a.axis @ b.axis) - 1.0) > 1e-3:
        return False
    offset = a.point - b.point
    offset -= (offset @ b.axis) * b.axis
    return bool(np.linalg.norm(offset) < 1e-2 * extent)


def _nearest_point_of_axes(axes: list[Symmetry]) -> Array:
    """The point (3,) nearest to all the axes, in the least-squares sense."""
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for s in axes:
        P = np.eye(3) - np.outer(s.axis, s.axis)
        A += P
        b += P @ s.point
    return np.linalg.lstsq(A, b, rcond=None)[0]
