"""The type of the cell's arm, `Robot`: what the cell and its planner need of any arm.

The arms themselves are made elsewhere: the built-in IRB 2400-class arm (irb2400_arm.py), the
UR5 of example-robot-data (ur5_arm.py), any 6-axis arm given as a URDF or a robot-only MJCF
file (file_robot.py), and the one the cell names (robots.py).

A `Robot` gives what the cell and its planner need of an arm:
- its nominal kinematics (Pinocchio) and, for a vector of deviations of its kinematic
  parameters, the deviated arm's (the real arm, drawn from the cell's seed; the calibrated
  arm, identified in the cell);
- the robot-only MJCF that MuJoCo simulates for those deviations: bodies `link1`..`link6`,
  joints and position servos `joint1`..`joint6`, a `flange` site where the tools lock;
- its home configuration, joint speeds and efforts, and who makes it (RAPID is ABB's).

The kinematic base frame is the cell's world frame: an arm standing elsewhere than the world's
origin (on a pedestal beside the table, say) carries its mount in its first joint's placement.

Deviations: the built-in arm has its twelve (six link lengths, six joint zero offsets, see
models.robot.ArmGeometry); any other arm has four per joint: the joint's zero offset [rad] and
the position of its axis in its parent link [m] (x, y, z), 24 in all.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from cell.cell_errors import CellConfigError
from cell.kinematics import Kinematics


@dataclass(frozen=True, eq=False)
class Robot:
    """An arm of the cell (see the module's docstring).

    Attributes:
        name: "irb2400", "ur5" or the file's stem.
        vendor: who makes it ("abb" gets RAPID programs; others the targets as CSV/JSON).
        q_home: (6,) home configuration [rad]: wrist above the table, flange down.
        joint_speed: (6,) speed limits [rad/s]; joint_effort: (6,) [N m].
        parameters: names of the kinematic deviations; lengths: (P,) True where a deviation
            is a length [m] (else an angle [rad]).
        tip_frame: the flange frame of the kinematics.
        T_world_base: (4, 4) where the arm's own base stands in the cell (its mount; the
            kinematics' base frame is the cell's, the mount in the first joint's placement).
        identified: (P,) bool, the deviations an in-cell calibration identifies (default
            all); the others it holds at zero.
        nominal_lengths: (P,) the nominal value of each length deviation's length [m] (0
            for an angle, and for a length that does not grow with the arm): what grows with
            the arm's temperature (`grown`). Default: none grows.
    """

    name: str
    vendor: str
    q_home: np.ndarray
    joint_speed: np.ndarray
    joint_effort: np.ndarray
    parameters: tuple[str, ...]
    lengths: np.ndarray
    _kinematics: Callable[[np.ndarray], Kinematics] = field(repr=False)
    _mjcf: Callable[[np.ndarray], str] = field(repr=False)
    tip_frame: str = "flange"
    T_world_base: np.ndarray = field(default_factory=lambda: np.eye(4))
    identified: np.ndarray | None = None
    nominal_lengths: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.identified is None:
            object.__setattr__(self, "identified", np.ones(len(self.parameters), dtype=bool))
        if self.nominal_lengths is None:
            object.__setattr__(self, "nominal_lengths", np.zeros(len(self.parameters)))

    def grown(self, strain: float) -> np.ndarray:
        """The deviations (P,) of the arm's links grown by `strain` (relative growth, dL/L:
        a material's expansion coefficient times its temperature rise) [m]."""
        assert self.nominal_lengths is not None  # set by __post_init__
        return float(strain) * self.nominal_lengths

    @property
    def rapid(self) -> bool:
        """Whether the arm's controller runs RAPID (an ABB arm)."""
        return self.vendor.lower() == "abb"

    def zero(self) -> np.ndarray:
        """The nominal arm's deviations (P,) (all zero)."""
        return np.zeros(len(self.parameters))

    def kinematics(self, deviations: np.ndarray | None = None) -> Kinematics:
        """Pinocchio kinematics of the arm with `deviations` (P,) (default: the nominal)."""
        return self._kinematics(self._check(deviations))

    def mjcf(self, deviations: np.ndarray | None = None) -> str:
        """The robot-only MJCF of the arm with `deviations` (P,) (default: the nominal)."""
        return self._mjcf(self._check(deviations))

    def draw_deviations(
        self, rng: np.random.Generator, length_sigma_m: float, angle_sigma_rad: float
    ) -> np.ndarray:
        """Deviations (P,) of a real arm: Gaussian, `length_sigma_m` on lengths and
        `angle_sigma_rad` on angles."""
        return rng.normal(0.0, 1.0, len(self.parameters)) * self.sigmas(
            length_sigma_m, angle_sigma_rad
        )

    def sigmas(self, length_sigma_m: float, angle_sigma_rad: float) -> np.ndarray:
        """(P,) the given sigma of each deviation by its kind (a prior, say)."""
        return np.where(self.lengths, length_sigma_m, angle_sigma_rad)

    def _check(self, deviations: np.ndarray | None) -> np.ndarray:
        if deviations is None:
            return self.zero()
        d = np.asarray(deviations, dtype=float)
        if d.shape != (len(self.parameters),) or not np.isfinite(d).all():
            raise CellConfigError(
                f"{self.name}: deviations must be {len(self.parameters)} finite numbers "
                f"({', '.join(self.parameters)}), got shape {d.shape}"
            )
        return d
