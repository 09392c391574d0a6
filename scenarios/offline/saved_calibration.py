"""A calibration kept beyond its job: the cell a run identified, as it writes it into its
folder (calibration.json), read back for a later job on the same cell (`twincell run
--calibration FILE`), as a real cell is calibrated when it is commissioned or after a crash
and not before every job.

The file holds the identified cell's model itself (the arm's deviations and joint
compliance, the laser's optical frame on its tool and its range scale, the table's terms,
the laser's latency where it was identified) and the calibration's figures, with the cell it
was made on and when (UTC). The model read back is the one the run used, to the bit (JSON
keeps a float64 exactly). A file of another cell, of a time to come or older than the job's
`calibration.max_age_h` is refused, saying what to change.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from cattrs.errors import BaseValidationError

from cell.kinematics import Kinematics
from cell.robot_arm import Robot
from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.cell_model import CellModel, CompliantKinematics, TableModel
from scenarios.offline.laser_latency import LatencyEstimate
from scenarios.results.evaluations import CalibrationSummary
from scenarios.results.json_converter import structure, unstructure
from scenarios.scenario_errors import ScenarioError

#: The saved calibration's file in a run folder.
CALIBRATION_FILE = "calibration.json"
#: The file's layout; a file of another layout is refused.
FORMAT = 1


@dataclass(frozen=True)
class SavedCalibration:
    """A calibration as a file keeps it: the cell it was made on (`cell`, as the job names
    it: "<arm>, seed <seed>") and when (`made_utc`, ISO 8601); its figures and what it found
    as results.json keeps them (`summary`: the arm's deviations by parameter name, the
    laser's mounting and scale, the table's terms, ...); and what the model needs besides:
    the joints' compliance (joints 2 and 3 [rad/(N m)], used where the summary's groups hold
    "stiffness"), the laser's optical frame on its tool (`T_tool_laser`, 4 x 4), the spheres'
    centres it found (S, 3) and the laser's latency where it was identified."""

    format: int
    cell: str
    made_utc: str
    summary: CalibrationSummary
    compliance: np.ndarray
    T_tool_laser: np.ndarray
    centres_table: np.ndarray
    latency: LatencyEstimate | None

    def age_s(self, now: datetime) -> float:
        """Seconds from when it was made to `now` (negative: made after `now`)."""
        return (now - datetime.fromisoformat(self.made_utc)).total_seconds()


def saved(result: CalibrationResult, cell: str, now: datetime) -> SavedCalibration:
    """`result` as the file keeps it, made on `cell` at `now` (aware, UTC)."""
    model = result.model
    kinematics = model.kinematics
    compliance = (
        kinematics.compliance[1:3].copy()
        if isinstance(kinematics, CompliantKinematics)
        else np.zeros(2)
    )
    return SavedCalibration(
        FORMAT, cell, now.astimezone(UTC).isoformat(),
        replace(result.summary(), given=None, check=None), compliance,
        np.asarray(model.T_tool_laser, dtype=float), np.asarray(result.centres_table),
        result.latency,
    )  # fmt: skip


def rebuilt(calibration: SavedCalibration, robot: Robot) -> CalibrationResult:
    """The calibration result of the saved one on the arm `robot` (its parameters must be the
    file's): the model the run used, its figures; no fitted points."""
    summary = calibration.summary
    deviations = np.array(list(summary.deviations.values()))
    links = robot.kinematics(deviations)
    kinematics: Kinematics = links
    if "stiffness" in summary.groups:
        kinematics = CompliantKinematics(links, calibration.compliance)
    table = np.array(summary.table_coefficients)
    model = CellModel(kinematics, calibration.T_tool_laser, summary.laser_scale, TableModel(table))
    return CalibrationResult(
        model, links, tuple(summary.deviations), deviations,
        np.array(summary.stiffness_nm_rad), np.array([*summary.laser_mount_m,
        *summary.laser_mount_rad]), summary.laser_scale, table, calibration.centres_table,
        summary.residual_rms_before_m, summary.residual_rms_after_m, summary.points,
        summary.views, summary.table_positions, summary.iterations, summary.groups,
        summary.seconds, None, calibration.latency,
    )  # fmt: skip


def to_json(calibration: SavedCalibration) -> dict[str, object]:
    """The file's content (a JSON object; a stiffness not modelled is written as null)."""
    data: dict[str, object] = unstructure(calibration)
    return data


def made_utc(path: Path) -> datetime:
    """When the calibration in `path` (a run's calibration.json) was made; ScenarioError for a
    file that is not one."""
    try:
        made = datetime.fromisoformat(
            json.loads(Path(path).read_text(encoding="utf-8"))["made_utc"]
        )
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ScenarioError(
            f"{path}: not a saved calibration ({exc}); give a run's {CALIBRATION_FILE}"
        ) from None
    return made


def read_calibration(
    path: Path, cell: str, robot: Robot, max_age_h: float, now: datetime
) -> SavedCalibration:
    """The calibration in `path` (a run's calibration.json), checked to be of this layout,
    of `cell` and the arm `robot`, made before `now` and at most `max_age_h` hours before it;
    ScenarioError naming what was given and what to change."""
    what = f"--calibration {path}"
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        if data.get("format") != FORMAT:
            raise ValueError(f"layout {data.get('format')!r}, this twincell reads {FORMAT}")
        calibration = structure(data, SavedCalibration)
        if datetime.fromisoformat(calibration.made_utc).tzinfo is None:
            raise ValueError(f"made_utc {calibration.made_utc!r} gives no time zone")
    except (OSError, ValueError, KeyError, TypeError, AttributeError, BaseValidationError) as exc:
        raise ScenarioError(
            f"{what}: not a saved calibration ({exc}); give a run's {CALIBRATION_FILE}"
        ) from None
    if calibration.cell != cell:
        raise ScenarioError(
            f"{what} was made on the cell {calibration.cell!r}; this job's cell is {cell!r}: "
            "give that cell's calibration, or leave --calibration out to calibrate now"
        )
    parameters = tuple(calibration.summary.deviations)
    if parameters != tuple(robot.parameters):
        raise ScenarioError(
            f"{what} holds the deviations of another arm model ({len(parameters)} "
            f"parameters, this arm has {len(robot.parameters)}): leave --calibration out to "
            "calibrate now"
        )
    age_h = calibration.age_s(now) / 3600.0
    if age_h < 0.0:
        raise ScenarioError(
            f"{what} was made at {calibration.made_utc}, after now ({now.isoformat()}): check "
            "the computer's clock"
        )
    if age_h > max_age_h:
        raise ScenarioError(
            f"{what} is {age_h:.1f} h old, more than calibration.max_age_h = {max_age_h:g} h: "
            "leave --calibration out to calibrate now, or raise calibration.max_age_h"
        )
    return calibration
