"""The cell's configuration: error sources of the real cell and the objects on the table.

Every error source has its own frozen dataclass and can be set to zero (`CellConfig.ideal()`).
Values are SI: [m], [rad].
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from cell.errors import CellConfigError
from cell.faults import Fault
from cell.robots import Robot, irb2400
from models.robot import RACK_POS


def _nonneg(owner: str, **values: float) -> None:
    for name, v in values.items():
        if not (np.isfinite(v) and v >= 0.0):
            raise CellConfigError(f"{owner}.{name} must be finite and >= 0, got {v!r}")


@dataclass(frozen=True)
class ArmErrors:
    """Kinematic deviations of the real arm from its nominal model (drawn once per cell).

    `length_sigma_m` per length deviation (the built-in arm's six link lengths; another arm's
    joint axis positions) and `offset_sigma_rad` per joint zero offset (see cell.robots).
    The defaults give an industrial arm's absolute accuracy, about 0.2-0.5 mm at the TCP.
    """

    length_sigma_m: float = 1.5e-4
    offset_sigma_rad: float = 1.0e-4

    def __post_init__(self) -> None:
        _nonneg(
            "ArmErrors", length_sigma_m=self.length_sigma_m, offset_sigma_rad=self.offset_sigma_rad
        )


@dataclass(frozen=True)
class DriveErrors:
    """The arm's drives between the motors (where the encoders are) and the links: what makes
    a real arm miss beyond its kinematic parameters. Each can be set to zero.

    - `stiffness_nm_rad` (joints 2, 3): gearbox torsional stiffness [N m/rad]; the links sag
      by the gravity torque of the arm and its payload over it (0: rigid). The real value is
      the nominal one times 1 + N(0, `stiffness_spread`). Default: 1.5e6 and 1.0e6 N m/rad,
      the order measured on industrial arms' joints 2 and 3 (Dumas et al., Joint stiffness
      identification of six-revolute industrial serial robots, Robotics and Computer-
      Integrated Manufacturing 27(4), 2011), giving 0.05-0.3 mm of sag at this arm's TCP.
    - `hysteresis_rad` (6,): lost motion per joint; the link stops half of it behind the
      motor, on the side it came from. Default 20 urad on the main axes and 40 urad on the
      wrist (4-8 arcsec: a precision cycloidal gear's lost motion seen through the motor's
      encoder after the controller's backlash compensation).
    - `repeat_sigma_rad`: per joint, where a pose reached again lands (redrawn each move).
      Default 1e-5 rad: about 0.03-0.06 mm at the TCP (3 sigma), the pose repeatability of an
      IRB 2400 (0.03-0.06 mm, ABB's product specification).
    - `drift_rad_per_s` (joints 2, 3): zero drift as the arm warms up (thermal growth),
      off by default; 1e-8 rad/s is about 0.04 mm an hour at the TCP.
    """

    stiffness_nm_rad: tuple[float, float] = (1.5e6, 1.0e6)
    stiffness_spread: float = 0.1
    hysteresis_rad: tuple[float, ...] = (2e-5, 2e-5, 2e-5, 4e-5, 4e-5, 4e-5)
    repeat_sigma_rad: float = 1.0e-5
    drift_rad_per_s: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if len(self.stiffness_nm_rad) != 2 or len(self.drift_rad_per_s) != 2:
            raise CellConfigError(
                "DriveErrors.stiffness_nm_rad and drift_rad_per_s take joints 2 and 3 (two "
                f"values), got {self.stiffness_nm_rad!r}, {self.drift_rad_per_s!r}"
            )
        if len(self.hysteresis_rad) != 6:
            raise CellConfigError(
                f"DriveErrors.hysteresis_rad takes six values, got {self.hysteresis_rad!r}"
            )
        _nonneg(
            "DriveErrors",
            stiffness_spread=self.stiffness_spread,
            repeat_sigma_rad=self.repeat_sigma_rad,
            **{f"stiffness_{j}": v for j, v in zip((2, 3), self.stiffness_nm_rad, strict=True)},
            **{f"hysteresis_{j + 1}": v for j, v in enumerate(self.hysteresis_rad)},
        )
        if not all(np.isfinite(self.drift_rad_per_s)):
            raise CellConfigError(
                f"DriveErrors.drift_rad_per_s must be finite, got {self.drift_rad_per_s!r}"
            )

    @classmethod
    def off(cls) -> DriveErrors:
        """Rigid, exact drives: the links where the motors are."""
        return cls((0.0, 0.0), 0.0, (0.0,) * 6, 0.0, (0.0, 0.0))

    @property
    def rigid(self) -> bool:
        """No compliance, no lost motion, no repeatability spread, no drift."""
        return (
            not any(self.stiffness_nm_rad)
            and not any(self.hysteresis_rad)
            and self.repeat_sigma_rad == 0.0
            and not any(self.drift_rad_per_s)
        )


@dataclass(frozen=True)
class ToolErrors:
    """The tools' true TCPs and how they seat on the flange.

    - `tcp_sigma_m`, `tcp_sigma_rad`: each tool's TCP off its nominal tooldata (drawn once:
      manufacturing). Default 0.05 mm and 0.25 mrad: ISO 2768-f (fine) general tolerances,
      +-0.15 mm over 30-120 mm as 3 sigma, and that much across the 0.2 m of the pointer.
    - `changer_sigma_m`, `changer_sigma_rad`: where a tool seats at each lock (redrawn at
      every tool change). Default 5 um and 20 urad: tool changers' repeatability of
      +-0.015 mm (3 sigma; ATI QC and SCHUNK SWS data sheets give +-0.01 to +-0.015 mm).
    - `laser_mount_sigma_m`, `laser_mount_sigma_rad`: the laser's optical frame off its
      nominal mounting on the tool plate (hand-eye), drawn once. Default 0.2 mm and 2 mrad.
    - `laser_scale_sigma`: the laser's range scale error (relative, drawn once). Default
      3e-4: a line scanner's linearity of 0.01-0.1 % of its measuring range.
    """

    tcp_sigma_m: float = 5.0e-5
    tcp_sigma_rad: float = 2.5e-4
    changer_sigma_m: float = 5.0e-6
    changer_sigma_rad: float = 2.0e-5
    laser_mount_sigma_m: float = 2.0e-4
    laser_mount_sigma_rad: float = 2.0e-3
    laser_scale_sigma: float = 3.0e-4

    @classmethod
    def off(cls) -> ToolErrors:
        """Every tool at its nominal TCP, seated exactly; the laser exact."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        _nonneg(
            "ToolErrors",
            tcp_sigma_m=self.tcp_sigma_m,
            tcp_sigma_rad=self.tcp_sigma_rad,
            changer_sigma_m=self.changer_sigma_m,
            changer_sigma_rad=self.changer_sigma_rad,
            laser_mount_sigma_m=self.laser_mount_sigma_m,
            laser_mount_sigma_rad=self.laser_mount_sigma_rad,
            laser_scale_sigma=self.laser_scale_sigma,
        )


@dataclass(frozen=True)
class EncoderNoise:
    """Gaussian noise [rad] on every joint reading (encoders and the laser's joint stamp)."""

    sigma_rad: float = 1.0e-5

    def __post_init__(self) -> None:
        _nonneg("EncoderNoise", sigma_rad=self.sigma_rad)


@dataclass(frozen=True)
class TableErrors:
    """Errors of the linear axis; its readout sees none of them.

    - `bias_sigma_m`: a constant positioning error drawn once; `repeat_sigma_m`: per move.
    - `straightness_sigma_m`: the carriage's sideways (x) and vertical (z) deviation from a
      straight travel, a bow over the travel whose amplitude is drawn once per direction.
    - `pitch_sigma_rad`, `yaw_sigma_rad`: the carriage's tilt about x and turn about z,
      varying linearly over the travel (its end values drawn once).
    Defaults (20 um, 25 urad): a precision linear guide over a metre of travel (ISO 230-1
    terms; about 5 arcsec of pitch and yaw and 0.02 mm of straightness).
    """

    bias_sigma_m: float = 1.0e-4
    repeat_sigma_m: float = 1.0e-5
    straightness_sigma_m: float = 2.0e-5
    pitch_sigma_rad: float = 2.5e-5
    yaw_sigma_rad: float = 2.5e-5

    def __post_init__(self) -> None:
        _nonneg(
            "TableErrors",
            bias_sigma_m=self.bias_sigma_m,
            repeat_sigma_m=self.repeat_sigma_m,
            straightness_sigma_m=self.straightness_sigma_m,
            pitch_sigma_rad=self.pitch_sigma_rad,
            yaw_sigma_rad=self.yaw_sigma_rad,
        )


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
        _nonneg("LaserConfig", sigma_m=self.sigma_m, dropout=self.dropout)
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
        _nonneg("IRConfig", sigma_m=self.sigma_m)
        if not 0.0 <= self.range_min_m < self.range_max_m:
            raise CellConfigError(
                f"IRConfig needs 0 <= range_min_m < range_max_m, got {self.range_min_m!r}, "
                f"{self.range_max_m!r}"
            )


def _check_T(owner: str, T: np.ndarray) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    ok = T.shape == (4, 4) and np.all(np.isfinite(T))
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
class CellConfig:
    """Everything that defines a simulated cell: its `robot` (cell.robots), where its tool
    rack stands (`rack_xyz` [m], the rack frame; the slots are 0.25 m apart along x and 0.8 m
    above it), the error sources, the objects on the table, the faults it will have
    (cell.faults). `seed` draws the real cell's errors."""

    seed: int = 0
    robot: Robot = field(default_factory=irb2400)
    rack_xyz: tuple[float, float, float] = RACK_POS
    arm: ArmErrors = field(default_factory=ArmErrors)
    drives: DriveErrors = field(default_factory=DriveErrors)
    tools: ToolErrors = field(default_factory=ToolErrors)
    encoder: EncoderNoise = field(default_factory=EncoderNoise)
    table: TableErrors = field(default_factory=TableErrors)
    laser: LaserConfig = field(default_factory=LaserConfig)
    ir: IRConfig = field(default_factory=IRConfig)
    fixtures: tuple[FixedMesh | FixedPrimitive, ...] = ()
    parts: tuple[LoosePart | LooseMesh, ...] = ()
    faults: tuple[Fault, ...] = ()

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

    def ideal(self) -> CellConfig:
        """The same cell with every error source set to zero (the nominal cell)."""
        return replace(
            self,
            arm=ArmErrors(0.0, 0.0),
            drives=DriveErrors.off(),
            tools=ToolErrors.off(),
            encoder=EncoderNoise(0.0),
            table=TableErrors(0.0, 0.0, 0.0, 0.0, 0.0),
            laser=replace(self.laser, sigma_m=0.0, dropout=0.0),
            ir=replace(self.ir, sigma_m=0.0),
            faults=(),
        )
