"""The runner's side of one job's stage loop (`JobRun`): what the runner does, with the real
cell's truth at hand, as each stage begins and ends (the stage tracker, the evaluator's
measurement of the poses, the recording, the run folder's scan.ply)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from scenarios.jobs.job_plan import JobPlan
from scenarios.jobs.run_log import RunLog
from scenarios.offline.cell_model import CellModel
from scenarios.outputs import run_files as outputs
from scenarios.realcell.evaluation import PoseEvaluation
from scenarios.realcell.setup import JobCell
from scenarios.results.verification_result import Verification
from scenarios.stages.calibrate_stage import Calibrated
from scenarios.stages.export_stage import Exported
from scenarios.stages.probe_stage import Probed
from scenarios.stages.register_stage import Registered
from scenarios.stages.scan_stage import Scanned
from scenarios.stages.stage import Outcome, Stage
from scenarios.stages.state import JobState, LocatedPose
from scenarios.stages.verify_stage import Verified


class JobRun:
    """The runner's side of one job's stage loop: as each stage begins, the run enters it
    (the stage tracker, the evaluator's fault injection, the recording's phase), and the
    poses are measured against the truth before the execution moves the part; as each ends,
    its time is kept and what it found is recorded (the recording, scan.ply)."""

    def __init__(
        self, cell: JobCell, run: RunLog, plan: JobPlan, folder: Path, recording: Any | None
    ) -> None:
        self.cell, self.run, self.folder, self.recording = cell, run, folder, recording
        self.virtual = plan.virtual
        self.methods = plan.settings.localization.methods
        self.timings: dict[str, float] = {}
        self.pose_errors: dict[str, PoseEvaluation] | None = None
        #: When the job's cell time began on the controller's clock [s]: the simulated cell's
        #: clock starts with the job (its settling at set-up counted in it); a controller
        #: across the network has run on before the job.
        self.started_s = 0.0 if cell.evaluator is not None else cell.controller.time_s
        self.time_at_verdict_s = cell.controller.time_s
        self.exported = Exported()
        self.verifications: list[Verification] = []
        self._t0 = time.perf_counter()

    def enter(self, stage: Stage, state: JobState) -> None:
        if stage.name == "execute":  # before the part moves (a pick)
            self.pose_errors = self.measure(state.ordered(self.methods), state.model)
        self.run.enter(stage.name)
        self.cell.log.phase(stage.name, stage.title)
        self._t0 = time.perf_counter()

    def saw(self, stage: Stage, outcome: Outcome, state: JobState) -> None:
        elapsed = time.perf_counter() - self._t0
        self.timings[stage.name] = self.timings.get(stage.name, 0.0) + elapsed
        controller, log, recording = self.cell.controller, self.cell.log, self.recording
        if isinstance(outcome, Calibrated):
            log.moved("view")
            if recording is not None:
                recording.log_calibration(controller.time_s, outcome.calibration)
        elif isinstance(outcome, Probed):
            log.moved("view")
            self.time_at_verdict_s = controller.time_s
        elif isinstance(outcome, Scanned):
            if recording is not None:
                recording.log_scan(outcome.scan.scan, outcome.scan.keep)
            log.moved("view")
            outputs.write_ply(self.folder / "scan.ply", outcome.scan.points_table)
        elif isinstance(outcome, Registered):
            self.time_at_verdict_s = controller.time_s
            self._log_registration(outcome.pose, state)
        elif isinstance(outcome, Verified):
            self._log_verification(outcome)
        elif isinstance(outcome, Exported):
            self.exported = outcome

    def measure(
        self, poses: tuple[LocatedPose, ...], model: CellModel
    ) -> dict[str, PoseEvaluation]:
        """Each method's pose against the truth, now (a pick may move the part later)."""
        evaluator = self.cell.evaluator
        if evaluator is None:  # no truth in this process
            return {}
        s0 = self.cell.controller.table_position()
        return {
            p.method: evaluator.pose_error(model.T_base_table(s0) @ p.T_table_object)
            for p in poses
            if p.T_table_object is not None
        }

    def _log_verification(self, outcome: Verified) -> None:
        self.verifications.append(outcome.verification)
        if self.recording is None:
            return
        targets_model = np.array([h.p_entry for h in self.virtual.burr_holes]).reshape(-1, 3)
        T = outcome.T_table_object
        self.recording.log_verification(
            self.cell.controller.time_s,
            outcome.verification,
            targets_model @ T[:3, :3].T + T[:3, 3],
            outcome.strip_table,
        )

    def _log_registration(self, pose: LocatedPose, state: JobState) -> None:
        located, scanned = pose.localization, state.scanned
        if self.recording is None or located is None or scanned is None:
            return
        self.recording.log_registration(
            self.cell.controller.time_s,
            located.result,
            self.virtual,
            scanned.points_table,
            located.points_used,
        )
