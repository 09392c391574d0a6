"""What the evaluator measured against the truth, as values: each target's error, a pose's
error, the pick, and the calibration's figures with the arm's true TCP error. Lengths [m],
angles [deg] where the name says so."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from scenarios.results.calibration_check_result import DriftCheck

if TYPE_CHECKING:  # only the protocol's annotation: the results load with numpy alone
    from models.model import ObjectModel


@dataclass(frozen=True, eq=False)
class TargetEvaluation:
    """One target: achieved tool tip against the true point on the real object.

    Attributes:
        error_m: distance of the achieved tip from the true touch point [m].
        axis_error_deg: angle between the tool axis and the true trajectory [deg].
        depth_error_m: distance of the tool axis, extended to the target depth, from the true
            deep target [m].
        registration_error_m: distance of the corrected target (the virtual target moved by
            the estimated pose) from the true one [m]: the registration's share of the error;
            the rest is the arm's positioning.
        p_true_base, p_achieved_base: (3,) the two points in the robot base frame [m].
    """

    name: str
    error_m: float
    axis_error_deg: float
    depth_error_m: float
    registration_error_m: float
    p_true_base: np.ndarray
    p_achieved_base: np.ndarray


@dataclass(frozen=True)
class PoseEvaluation:
    """An estimated pose against the true one, in the base frame: rotation [deg] and
    translation [m]."""

    rotation_error_deg: float
    translation_error_m: float


@dataclass(frozen=True)
class PickEvaluation:
    """A pick and put-down measured on the true part.

    Attributes:
        lifted_m: rise of the part's frame origin from its rest pose to the lifted pose [m].
        slip_m: displacement of the part's grip point (its grasp frame's origin) in the
            gripper's true TCP frame from the closing of the fingers to the end of the lift
            and hold [m].
        placed_displacement_m: translation of the part's true pose from its rest before the
            pick to its rest after the put-down [m].
        placed_rotation_deg: rotation between the same two poses [deg].
    """

    lifted_m: float
    slip_m: float
    placed_displacement_m: float
    placed_rotation_deg: float


@dataclass(frozen=True)
class TcpError:
    """A kinematic model's TCP error against the real arm at the job's configurations:
    mean and max distance of the real TCP from the model's [m]."""

    mean_m: float
    max_m: float


@dataclass(frozen=True)
class CalibrationSummary:
    """The calibration's own figures (scenarios.offline.calibration.CalibrationResult): the
    residual RMS of the sphere fits before and after [m], its wall time [s], the points,
    views, table positions and iterations it used, the parameter groups it identified, and
    what it found: each kinematic parameter's deviation ([m] or [rad]), the joints'
    stiffness [N m/rad] (inf: not modelled), the laser's mounting ([m], [rad]) and range
    scale, and the table's coefficients; the laser's latency [s] and its uncertainty [s] where
    it was identified (a laser whose lines are paired with the arm by time), else None; the
    saved calibration the job was `given` (`twincell run --calibration`), else None, and its
    quick `check` (where it failed, the figures are of the calibration made anew)."""

    residual_rms_before_m: float
    residual_rms_after_m: float
    seconds: float
    points: int
    views: int
    table_positions: int
    iterations: int
    groups: tuple[str, ...]
    deviations: dict[str, float]
    stiffness_nm_rad: tuple[float, ...]
    laser_mount_m: tuple[float, ...]
    laser_mount_rad: tuple[float, ...]
    laser_scale: float
    table_coefficients: tuple[tuple[float, ...], ...]
    laser_latency_s: float | None = None
    laser_latency_sigma_s: float | None = None
    given: str | None = None
    check: DriftCheck | None = None


@dataclass(frozen=True)
class CalibrationFigures:
    """The calibration's figures (None if the job did not calibrate) and, from the truth,
    the tool's TCP error of the nominal and the calibrated arm at `configurations` of the
    job's (None: no truth in the job's process, a controller across the network)."""

    summary: CalibrationSummary | None
    nominal: TcpError | None
    calibrated: TcpError | None
    configurations: int

    @property
    def enabled(self) -> bool:
        return self.summary is not None


class TouchMeasure(Protocol):
    """What measures the job's touches against the truth: told of each touch as it happens
    (`record_touch`), asked afterwards for each touched target's evaluation (`targets`, as
    the evaluator gives them: the touch named `prefix` + the target's name, the estimated
    pose (4, 4) giving the registration's share)."""

    def record_touch(self, target: str, tool: str) -> None: ...

    def targets(
        self,
        touch_offset_m: float,
        virtual: ObjectModel,
        T_base_object_estimate: np.ndarray,
        prefix: str = "",
    ) -> tuple[TargetEvaluation, ...]: ...
