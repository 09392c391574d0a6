"""The one pipeline of every cell job: plan it in its virtual cell, build its real cell, run
its stages in one loop, and ask the evaluator afterwards what really happened.

The runner (`run_cell_job`) alone holds the real cell's truth: it sets the cell up
(scenarios.realcell), hands the stages (scenarios.stages) a context with the controller
API, the virtual model, the planning settings and the job so far, nothing else, and has the
job reported against the truth (scenarios.jobs.job_report). What the run records of the truth
(the evaluator's moments, the rerun recording of the bodies) goes through the hooks the
runner passes to the stages, and through what it does as each stage begins and ends
(`JobRun`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from cell.robot_arm import Robot
from cell.sim.faults import FAULT_KINDS, Fault
from models.model import ObjectModel
from scenarios.configuration.job_config import JobConfig
from scenarios.jobs.commissioner import Commissioner
from scenarios.jobs.job_plan import JobPlan, plan_job
from scenarios.jobs.job_report import finish_job
from scenarios.jobs.job_run import JobRun
from scenarios.jobs.network_job import ControllerAddress, network_job_cell
from scenarios.jobs.run_log import RunLog
from scenarios.jobs.stage_tracker import StageTracker
from scenarios.offline.cell_model import CellModel
from scenarios.offline.operations import target_operations
from scenarios.realcell.cell_log import CellLog
from scenarios.realcell.setup import JobCell, build_job_cell
from scenarios.results.beam import Commissioning
from scenarios.results.budget_result import ErrorBudget
from scenarios.results.evaluations import TouchMeasure
from scenarios.results.run import RunResult
from scenarios.results.verification_result import TcpCheck
from scenarios.scenario_errors import ScenarioError
from scenarios.stages.calibrate_stage import Calibrate
from scenarios.stages.check_stage import Check
from scenarios.stages.context import StageContext
from scenarios.stages.execute_stage import Execute
from scenarios.stages.export_stage import Export
from scenarios.stages.loop import run_stages
from scenarios.stages.probe_stage import Probe
from scenarios.stages.register_stage import Register
from scenarios.stages.scan_stage import Scan
from scenarios.stages.stage import Stage
from scenarios.stages.state import JobState
from scenarios.stages.verify_stage import Verify

Progress = Callable[[str], None]


# -- the runner's hooks: the truth recorded at the stages' moments -------------------------------
class RunHooks:
    """The stages' moments go to what measures the touches (the evaluator records the truth
    then; across the network the twin does), their moves to the recording (the true bodies,
    the arm's path), their progress and their checks to the run's `say`, `detect`, `checked`
    and `budgeted`; the cell's commissioning is the runner's (`Commissioner`)."""

    def __init__(
        self,
        touches: TouchMeasure,
        log: CellLog,
        say: Progress,
        detect: Callable[[str, str, str], None],
        checked: Callable[[TcpCheck], None],
        budgeted: Callable[[ErrorBudget], None],
        commissioning: Callable[[], Commissioning | None],
    ) -> None:
        self._touches = touches
        self._log = log
        self.say = say
        self.detect = detect
        self.checked = checked
        self.budgeted = budgeted
        self.commissioning = commissioning

    def moment(self, name: str, tool: str) -> None:
        self._touches.record_touch(name, tool)

    def moved(self, what: str) -> None:
        self._log.moved(what)


def job_cell(
    config: JobConfig,
    virtual: ObjectModel,
    real: ObjectModel,
    robot: Robot,
    recording: Any | None = None,
    faults: tuple[Fault, ...] = (),
) -> JobCell:
    """The job's real cell (scenarios.realcell.setup.build_job_cell)."""
    return build_job_cell(config, virtual, real, robot, recording, faults)


def job_faults(
    config: JobConfig, virtual: ObjectModel, T_table_nominal: np.ndarray
) -> tuple[Fault, ...]:
    """The faults the job's real cell will have (`faults:`), each kind's defaults filled
    in: the job's tool for a payload, and an obstacle standing 5 cm behind the first
    operation's approach point (nominal), where the tool passes on its way there."""
    out = []
    for name, setting in config.faults.active().items():
        kind = FAULT_KINDS[name]
        option = setting.option
        if name == "payload" and option is None:
            option = config.operations.tool
        where: tuple[float, float, float] | None = None
        if name == "obstacle":
            ops = target_operations(virtual, config.operations)
            T = T_table_nominal @ ops[0].T_object_approach
            x, y, z = (float(v) for v in T[:3, 3] - 0.05 * T[:3, 2])
            where = (x, y, z)
        out.append(
            Fault(
                name,
                kind.default if setting.amount is None else setting.amount,
                kind.stage if setting.stage is None else setting.stage,
                option,
                where,
            )
        )
    return tuple(out)


def job_stages(
    config: JobConfig, plan: JobPlan, calibration: Path | None = None
) -> tuple[Stage, ...]:
    """The job's stages, in order: calibrate (if the job calibrates: the calibration
    `calibration` an earlier run saved where given), probe and scan +
    register (its localization methods), check, verify (a surface match, if the job
    verifies: a disagreement runs scan, register and check again), execute, export."""
    methods = config.localization.methods
    stages: list[Stage] = [Calibrate(calibration)] if config.calibration.enabled else []
    if "probe" in methods:
        stages.append(Probe())
    localize: tuple[Stage, ...] = ()
    if "surface" in methods:
        localize = (Scan(plan.scan_plan), Register())
    stages += [*localize, Check()]
    if methods[0] == "surface" and config.verify.enabled:
        stages.append(Verify((*localize, Check())))
    stages.append(Execute(f"the program corrected by the {methods[0]} pose"))
    stages.append(Export(config.export.compensation))
    return tuple(stages)


def run_cell_job(
    config: JobConfig,
    folder: Path,
    progress: Progress | None = None,
    recording: Any | None = None,
    stages: StageTracker | None = None,
    use_cache: bool = True,
    address: ControllerAddress | None = None,
    commissioning: Path | None = None,
    calibration: Path | None = None,
) -> RunResult:
    """Run a cell job into `folder`; returns its result (written by the caller). `stages`
    hears each stage as it begins; `use_cache`: the skull phantom and the scan plan may come
    from the user's cache folder (see plan_job); `address`: the controller across the network
    the job runs on (None: the job's real cell, simulated here); `commissioning`: the cell's
    commissioning record from an earlier run (None: the job commissions when it first needs
    to, scenarios.jobs.commissioner); `calibration`: the cell's calibration an earlier run
    saved (None: the job calibrates, where it calibrates at all)."""
    given = (commissioning, calibration)
    say = progress or (lambda _msg: None)
    t_total = time.perf_counter()
    if calibration is not None and not config.calibration.enabled:
        raise ScenarioError(
            f"--calibration {calibration} is given to a job that keeps the data sheet's cell "
            "(calibration.enabled: false): leave one of them out"
        )
    if address is not None:
        address.check_laser(config.cell.laser.kind)  # before any planning
    plan = plan_job(config, say, use_cache)
    if address is not None:
        if not config.calibration.enabled and config.calibration.latency == "identify":
            say(
                "warning: with the calibration off, the laser's latency is not identified: its "
                "lines are paired with the encoders of their stamps (calibration.latency gives "
                "the data sheet's)"
            )
        cell, remote = network_job_cell(config, plan, address, recording)
        try:
            return _run_stages(
                config, plan, cell, folder, say, t_total, stages, recording, (), given
            )
        finally:
            say(f"the link to {address.url}: {remote.link_summary()}")
            remote.close()
    faults = job_faults(config, plan.virtual, plan.T_table_nominal)
    cell = job_cell(config, plan.virtual, plan.real, plan.robot, recording, faults)
    return _run_stages(config, plan, cell, folder, say, t_total, stages, recording, faults, given)


def _run_stages(
    config: JobConfig,
    plan: JobPlan,
    cell: JobCell,
    folder: Path,
    say: Progress,
    t_total: float,
    stages: StageTracker | None,
    recording: Any | None,
    faults: tuple[Fault, ...],
    given: tuple[Path | None, Path | None] = (None, None),
) -> RunResult:
    """The job's stages on its `cell`, in one loop, and its result; `given`: the cell's
    commissioning record and calibration from earlier runs, where given."""
    if recording is not None and plan.scan_plan is not None:
        recording.log_scan_plan(0.0, plan.scan_plan)
    if faults:
        say("faults injected: " + ", ".join(f.name for f in faults))
    log = RunLog(cell.controller, cell.evaluator, cell.log, say, stages, recording)
    job = JobRun(cell, log, plan, folder, recording)
    commissioning = Commissioner(config, plan, job, log.say, given[0])
    hooks = RunHooks(
        cell.touches, cell.log, log.say, log.detect, log.checked, log.budgeted, commissioning
    )
    controller = cell.controller
    ctx = StageContext(
        controller, plan.virtual, plan.T_table_nominal, cell.box, plan.settings, hooks,
        JobState.start(CellModel.nominal(controller.nominal_kinematics)), folder, plan.user,
    )  # fmt: skip
    job.timings["setup"] = time.perf_counter() - t_total
    ran = run_stages(job_stages(config, plan, given[1]), ctx, job.enter, job.saw)
    return finish_job(config, plan, job, ran, t_total)
