"""The cell's layout as its designer and its planner know it: the objects on the table (meshes
and primitives, fixed or loose), the laser's and the IR sensor's data sheets, the arm and the
rack's place. Nothing here is drawn or hidden: the real cell's errors are `cell.sim`'s.
Values are SI: [m], [rad].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from cell.cell_errors import CellConfigError
from cell.irb2400_arm import irb2400
from cell.robot_arm import Robot
from models.robot import RACK_POS


def nonneg(owner: str, **values: float) -> None:
    for name, v in values.items():
        if not (np.isfinite(v) and v >= 0.0):
            raise CellConfigError(f"{owner}.{name} must be finite and >= 0, got {v!r}")


@dataclass(frozen=True)
class LaserConfig:
    """The laser line scanner: `n_rays` in a fan of `fan_angle_rad` in the TCP's x-z plane
    (centred on its z axis), returns only between `range_min_m` and `range_max_m`, Gaussian
    range noise `sigma_m`, no return beyond `max_incidence_rad` from the surface normal, and a
    random dropout probability per ray."""

    n_rays: int = 256
    fan_angle_rad: float = 0.6
    range_min_m: float = 0.05
    range_max_m: float = 0.6
    sigma_m: float = 2.0e-5
    max_incidence_rad: float = 1.3
    dropout: float = 0.0

    def __post_init__(self) -> None:
        if not (isinstance(self.n_rays, int) and 1 <= self.n_rays <= 100_000):
            raise CellConfigError(
                f"LaserConfig.n_rays must be an int in [1, 100000], got {self.n_rays!r}"
            )
        nonneg("LaserConfig", sigma_m=self.sigma_m, dropout=self.dropout)
        if not 0.0 <= self.fan_angle_rad < np.pi:
            raise CellConfigError(
                f"LaserConfig.fan_angle_rad must be in [0, pi), got {self.fan_angle_rad!r}"
            )
        if not 0.0 <= self.range_min_m < self.range_max_m:
            raise CellConfigError(
                f"LaserConfig needs 0 <= range_min_m < range_max_m, got {self.range_min_m!r}, "
                f"{self.range_max_m!r}"
            )
        if not 0.0 < self.max_incidence_rad <= np.pi / 2:
            raise CellConfigError(
                "LaserConfig.max_incidence_rad must be in (0, pi/2], "
                f"got {self.max_incidence_rad!r}"
            )
        if self.dropout > 1.0:
            raise CellConfigError(f"LaserConfig.dropout must be in [0, 1], got {self.dropout!r}")

    def directions_tcp(self) -> np.ndarray:
        """(n_rays, 3) unit ray directions in the laser TCP frame."""
        angles = np.linspace(-self.fan_angle_rad / 2, self.fan_angle_rad / 2, self.n_rays)
        return np.stack([np.sin(angles), np.zeros_like(angles), np.cos(angles)], axis=1)


@dataclass(frozen=True)
class IRConfig:
    """The IR proximity sensor: one ray along its TCP z axis, short range, Gaussian noise."""

    range_min_m: float = 0.005
    range_max_m: float = 0.15
    sigma_m: float = 2.0e-4

    def __post_init__(self) -> None:
        nonneg("IRConfig", sigma_m=self.sigma_m)
        if not 0.0 <= self.range_min_m < self.range_max_m:
            raise CellConfigError(
                f"IRConfig needs 0 <= range_min_m < range_max_m, got {self.range_min_m!r}, "
                f"{self.range_max_m!r}"
            )


def _check_T(owner: str, T: np.ndarray) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    ok = T.shape == (4, 4) and bool(np.all(np.isfinite(T)))
    if ok:
        R = T[:3, :3]
        ok = bool(np.allclose(R.T @ R, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0)
        ok = ok and bool(np.allclose(T[3], [0, 0, 0, 1]))
    if not ok:
        raise CellConfigError(f"{owner} must be a rigid (4, 4) transform, got {T!r}")
    return T


def _check_mesh_object(obj: FixedMesh | LooseMesh, owner: str) -> None:
    """Validate a mesh object's vertices, faces, convex pieces and pose, and store them as
    (N, 3) float, (M, 3) int32 and a (4, 4) float transform."""
    v, f = _check_mesh(owner, obj.vertices, obj.faces, obj.convex_pieces)
    object.__setattr__(obj, "vertices", v)
    object.__setattr__(obj, "faces", f)
    T = _check_T(f"{owner} T_table_object", obj.T_table_object)
    object.__setattr__(obj, "T_table_object", T)


def _check_mesh(
    owner: str, vertices: np.ndarray, faces: np.ndarray, convex_pieces: tuple[np.ndarray, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """Validated (N, 3) float vertices and (M, 3) int32 faces of a mesh object."""
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 4 or not np.all(np.isfinite(v)):
        raise CellConfigError(f"{owner}: vertices must be finite (N>=4, 3), got shape {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] < 1 or not np.issubdtype(f.dtype, np.integer):
        raise CellConfigError(f"{owner}: faces must be integer (M, 3), got shape {f.shape}")
    if f.min() < 0 or f.max() >= v.shape[0]:
        raise CellConfigError(
            f"{owner}: face indices must be in [0, {v.shape[0]}), got [{f.min()}, {f.max()}]"
        )
    for i, piece in enumerate(convex_pieces):
        p = np.asarray(piece, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 4 or not np.all(np.isfinite(p)):
            raise CellConfigError(
                f"{owner}: convex piece {i} must be finite (K>=4, 3), got {p.shape}"
            )
    return v, f.astype(np.int32)


@dataclass(frozen=True, eq=False)
class FixedMesh:
    """A mesh object fixed on the table at `T_table_object` (its TRUE pose in the real cell).

    `vertices` (N, 3) [m] and `faces` (M, 3) int in the object frame. Rays hit the exact
    triangles. For contact, MuJoCo uses convex hulls: give `convex_pieces` (each a (K, 3)
    vertex array in the object frame) for a concave object; without them the mesh's own hull
    collides.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    T_table_object: np.ndarray
    convex_pieces: tuple[np.ndarray, ...] = ()
    rgba: tuple[float, float, float, float] = (0.9, 0.85, 0.75, 1.0)

    def __post_init__(self) -> None:
        _check_mesh_object(self, f"FixedMesh {self.name!r}")


@dataclass(frozen=True, eq=False)
class LooseMesh:
    """A mesh object lying loose on the table: a free body that starts at `T_table_object`
    (its TRUE initial pose; it then moves as physics moves it) and that a gripper can pick.

    `vertices` (N, 3) [m] and `faces` (M, 3) int in the object frame, a closed surface: rays
    hit its exact triangles and its mass properties come from its volume. Contacts use
    `convex_pieces` (each a (K, 3) vertex array in the object frame; without them the mesh's
    own hull). The mass is `mass_kg` if given, else the volume times `density_kg_m3` (the
    default is aluminium's); `friction` is the sliding friction coefficient of its contacts
    (MuJoCo takes the larger of the two geoms' coefficients).
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    T_table_object: np.ndarray
    convex_pieces: tuple[np.ndarray, ...] = ()
    density_kg_m3: float = 2700.0
    mass_kg: float | None = None
    friction: float = 1.0
    rgba: tuple[float, float, float, float] = (0.9, 0.85, 0.75, 1.0)

    def __post_init__(self) -> None:
        owner = f"LooseMesh {self.name!r}"
        _check_mesh_object(self, owner)
        for name, value in (("density_kg_m3", self.density_kg_m3), ("friction", self.friction)):
            if not (np.isfinite(value) and value > 0):
                raise CellConfigError(f"{owner}: {name} must be finite and > 0, got {value!r}")
        if self.mass_kg is not None and not (np.isfinite(self.mass_kg) and self.mass_kg > 0):
            raise CellConfigError(
                f"{owner}: mass_kg must be None (from the volume) or > 0, got {self.mass_kg!r}"
            )


@dataclass(frozen=True, eq=False)
class FixedPrimitive:
    """A primitive fixed on the table: a sphere (size = (radius,)) or a box (half sizes)."""

    name: str
    kind: Literal["sphere", "box"]
    size: tuple[float, ...]
    T_table_object: np.ndarray
    rgba: tuple[float, float, float, float] = (0.8, 0.8, 0.85, 1.0)

    def __post_init__(self) -> None:
        n = {"sphere": 1, "box": 3}.get(self.kind)
        if n is None:
            raise CellConfigError(
                f"FixedPrimitive kind must be 'sphere' or 'box', got {self.kind!r}"
            )
        if len(self.size) != n or not all(np.isfinite(s) and s > 0 for s in self.size):
            raise CellConfigError(
                f"FixedPrimitive {self.name!r} ({self.kind}) needs {n} positive sizes, "
                f"got {self.size!r}"
            )
        object.__setattr__(
            self,
            "T_table_object",
            _check_T(f"FixedPrimitive {self.name!r} T_table_object", self.T_table_object),
        )


@dataclass(frozen=True)
class LoosePart:
    """A free box resting on the table: half sizes [m], mass [kg], centre (x, y) in the table
    frame [m] (it is dropped onto the top surface)."""

    name: str
    half_size: tuple[float, float, float] = (0.02, 0.02, 0.02)
    mass: float = 0.1
    xy_table: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if len(self.half_size) != 3 or not all(np.isfinite(s) and s > 0 for s in self.half_size):
            raise CellConfigError(
                f"LoosePart {self.name!r} needs 3 positive half sizes, got {self.half_size!r}"
            )
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise CellConfigError(
                f"LoosePart {self.name!r} needs a positive mass, got {self.mass!r}"
            )


@dataclass(frozen=True)
class CellLayout:
    """The cell as it is designed: its `robot` (cell.robot_arm, its data sheet), where its tool
    rack stands (`rack_xyz` [m], the rack frame; the slots are 0.25 m apart along x and 0.8 m
    above it), the laser's data sheet, and the objects on the table at the poses given."""

    robot: Robot = field(default_factory=irb2400)
    rack_xyz: tuple[float, float, float] = RACK_POS
    laser: LaserConfig = field(default_factory=LaserConfig)
    fixtures: tuple[FixedMesh | FixedPrimitive, ...] = ()
    parts: tuple[LoosePart | LooseMesh, ...] = ()

    def __post_init__(self) -> None:
        rack = np.asarray(self.rack_xyz, dtype=float)
        if rack.shape != (3,) or not np.isfinite(rack).all() or not -0.5 <= rack[2] <= 1.0:
            raise CellConfigError(
                f"rack_xyz must be 3 finite numbers [m] with the rack's z in [-0.5, 1.0] (its "
                f"slots 0.8 m above it), got {self.rack_xyz!r}"
            )
        names = [o.name for o in (*self.fixtures, *self.parts)]
        if len(set(names)) != len(names):
            raise CellConfigError(f"object names on the table must be unique, got {names}")
        for obj in self.fixtures:
            if not isinstance(obj, FixedMesh | FixedPrimitive):
                raise CellConfigError(
                    f"fixtures must be FixedMesh or FixedPrimitive, got {type(obj).__name__}"
                )
        for part in self.parts:
            if not isinstance(part, LoosePart | LooseMesh):
                raise CellConfigError(
                    f"parts must be LoosePart or LooseMesh, got {type(part).__name__}"
                )
