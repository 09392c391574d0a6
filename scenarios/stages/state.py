"""What a job's stages have found so far: each localization method's pose (`LocatedPose`),
the latest scan (`ScanStage`), the corrected programs (`ProgramStage`), and the state each
stage's outcome moves on (`JobState`, scenarios.stages.stage)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.cell_model import CellModel
from scenarios.offline.localization import Localization
from scenarios.offline.probing import ProbeResult
from scenarios.offline.scan_passes import PlannedPass, ScanData
from scenarios.program.program_types import OfflineProgram


@dataclass(frozen=True, eq=False)
class LocatedPose:
    """One localization method's pose of the object in the nominal table frame (4, 4), or
    None; whether it may drive a program, and why not."""

    method: str
    T_table_object: np.ndarray | None
    accepted: bool
    reason: str
    localization: Localization | None = None
    probe: ProbeResult | None = None


@dataclass(frozen=True, eq=False)
class ScanStage:
    """The scan: what the laser measured, which points were kept as the object's (N,),
    those points (M, 3) in the nominal table frame, and the passes it ran."""

    scan: ScanData
    keep: np.ndarray
    points_table: np.ndarray
    plan: tuple[PlannedPass, ...] = ()
    scan_time_s: float = 0.0


@dataclass(frozen=True, eq=False)
class ProgramStage:
    """The corrected programs: the pick (if any) and the operations, by method."""

    pick: OfflineProgram | None
    operations: dict[str, OfflineProgram]


@dataclass(frozen=True, eq=False)
class JobState:
    """The job so far: the cell `model` the stages believe (nominal, then calibrated), the
    `calibration`, each localization method's pose in the order found, the latest scan, the
    corrected programs, and the stage that refused them beyond the match's own verdict."""

    model: CellModel
    calibration: CalibrationResult | None = None
    poses: tuple[LocatedPose, ...] = ()
    scanned: ScanStage | None = None
    programs: ProgramStage = field(default_factory=lambda: ProgramStage(None, {}))
    refused_by: str | None = None

    @classmethod
    def start(cls, model: CellModel) -> JobState:
        """A job before its first stage: nothing found, the cell `model` believed."""
        return cls(model)

    def pose(self, method: str) -> LocatedPose | None:
        """The pose found by `method` ("surface", "probe"), or None."""
        return next((p for p in self.poses if p.method == method), None)

    def ordered(self, methods: tuple[str, ...]) -> tuple[LocatedPose, ...]:
        """The poses of `methods` that were found, in that order (the first drives)."""
        return tuple(p for m in methods if (p := self.pose(m)) is not None)

    def primary(self, methods: tuple[str, ...]) -> LocatedPose:
        """The pose that drives the program: that of the first of `methods`."""
        pose = self.pose(methods[0])
        if pose is None:
            raise LookupError(f"no {methods[0]} pose yet; found: {[p.method for p in self.poses]}")
        return pose

    def without_programs(self) -> JobState:
        """The state with no corrected program (none planned, or all refused)."""
        return replace(self, programs=ProgramStage(None, {}))

    def refused(self, method: str, reason: str, stage: str) -> JobState:
        """The state after `stage` refused the pose of `method` for `reason`: that pose no
        longer accepted, no program left."""
        pose = self.pose(method)
        assert pose is not None
        refused = replace(pose, accepted=False, reason=reason)
        return replace(self.with_pose(refused).without_programs(), refused_by=stage)

    def with_pose(self, pose: LocatedPose) -> JobState:
        """The state with `pose` in place of its method's earlier one (or added)."""
        kept = tuple(p for p in self.poses if p.method != pose.method)
        if len(kept) == len(self.poses):
            return replace(self, poses=(*self.poses, pose))
        poses = tuple(pose if p.method == pose.method else p for p in self.poses)
        return replace(self, poses=poses)
