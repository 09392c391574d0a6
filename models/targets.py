"""Operation targets in an object's model frame: burr holes (skull) and named frames (parts);
and the IR probe lines across a flat part's edges (2D adjusting)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.model_errors import MeshDataError


def _vector3(value: np.ndarray, what: str) -> np.ndarray:
    v = np.array(value, dtype=float)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise MeshDataError(f"{what} must be a finite 3-vector, got {value!r}")
    v.setflags(write=False)
    return v


def frame_from_z(p_origin: np.ndarray, z_axis: np.ndarray) -> np.ndarray:
    """A 4x4 transform with origin `p_origin` [m] and unit z along `z_axis`.

    The x axis is the model x axis projected onto the plane normal to z (model y when z is
    nearly parallel to model x), so that the frame is fixed by (origin, z) alone.
    """
    z = np.asarray(z_axis, dtype=float)
    z = z / np.linalg.norm(z)
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - (ref @ z) * z
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, p_origin
    return T


@dataclass(frozen=True, eq=False)
class BurrHole:
    """A burr hole on the skull and the trajectory through it, in the model frame.

    `p_entry` (3,) [m] lies on the outer surface, `direction` (3,) is the unit trajectory
    pointing into the skull, `depth` [m] is the distance from the entry to the deep target.
    """

    name: str
    p_entry: np.ndarray
    direction: np.ndarray
    depth: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "p_entry", _vector3(self.p_entry, "p_entry"))
        d = np.array(self.direction, dtype=float)
        n = float(np.linalg.norm(d)) if d.shape == (3,) else 0.0
        if not n > 0 or not np.isfinite(n):
            raise MeshDataError(f"direction must be a non-zero 3-vector, got {self.direction!r}")
        object.__setattr__(self, "direction", _vector3(d / n, "direction"))
        if not self.depth > 0:
            raise MeshDataError(f"depth must be positive [m], got {self.depth}")

    @property
    def p_target(self) -> np.ndarray:
        """The deep target, (3,) [m]: entry + depth * direction."""
        return self.p_entry + self.depth * self.direction

    @property
    def T_model_entry(self) -> np.ndarray:
        """Entry frame (4, 4): origin at the entry, z along the trajectory into the skull."""
        return frame_from_z(self.p_entry, self.direction)


@dataclass(frozen=True, eq=False)
class OperationFrame:
    """A named operation frame of a part: `kind` is grasp, insert or screw.

    `T_part_frame` (4, 4) maps frame coordinates into the part frame [m]. For insert and screw
    the frame's z axis is the approach direction (pointing into the part).
    """

    name: str
    kind: str
    T_part_frame: np.ndarray

    KINDS = ("grasp", "insert", "screw")

    def __post_init__(self) -> None:
        if self.kind not in self.KINDS:
            raise MeshDataError(f"operation kind must be one of {self.KINDS}, got {self.kind!r}")
        T = np.array(self.T_part_frame, dtype=float)
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise MeshDataError(f"T_part_frame must be a finite 4x4 matrix, got {T.shape}")
        R = T[:3, :3]
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise MeshDataError(f"T_part_frame of {self.name!r} is not a rigid transform")
        if not np.allclose(T[3], [0, 0, 0, 1]):
            raise MeshDataError(f"T_part_frame of {self.name!r} has a bottom row {T[3]}")
        T.setflags(write=False)
        object.__setattr__(self, "T_part_frame", T)


@dataclass(frozen=True, eq=False)
class ProbeLine:
    """An IR probe line across one straight edge of a flat part, in the part frame [m].

    `p_inside` (3,) lies on the part's top face, `p_outside` (3,) beyond the edge on the
    table; the edge is the line {x: normal . x = offset} of the part frame, `normal` (3,) the
    unit outward normal in the table plane; `step_m` is the height of the part at the edge
    (the step the IR sensor sees).
    """

    name: str
    p_inside: np.ndarray
    p_outside: np.ndarray
    normal: np.ndarray
    offset: float
    step_m: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "p_inside", _vector3(self.p_inside, "p_inside"))
        object.__setattr__(self, "p_outside", _vector3(self.p_outside, "p_outside"))
        n = np.array(self.normal, dtype=float)
        if n.shape != (3,) or not np.isclose(np.linalg.norm(n), 1.0, atol=1e-9) or n[2] != 0:
            raise MeshDataError(f"normal must be a horizontal unit vector, got {self.normal!r}")
        object.__setattr__(self, "normal", _vector3(n, "normal"))
        if not self.step_m > 0:
            raise MeshDataError(f"step_m must be positive [m], got {self.step_m}")
