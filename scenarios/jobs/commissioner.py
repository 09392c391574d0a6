"""The cell's commissioning as a job meets it: the reference its TCP checks compare a tool
with. Made when a stage first asks (scenarios.offline.commissioning), or given: the record an
earlier run on the same cell wrote (`twincell run --commissioning FILE`), as a cell is
commissioned once and its record kept.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

from cattrs.errors import BaseValidationError

from cell import Controller
from scenarios.configuration.job_config import JobConfig
from scenarios.jobs.job_plan import JobPlan
from scenarios.jobs.job_run import JobRun
from scenarios.offline.commissioning import COMMISSIONING_FILE, cell_label, commission
from scenarios.offline.tcp_check import POINTERS
from scenarios.outputs.run_folder import write_json
from scenarios.realcell.setup import build_job_cell
from scenarios.results.beam import Commissioning
from scenarios.results.json_converter import structure, unstructure
from scenarios.scenario_errors import ScenarioError

Progress = Callable[[str], None]


def read_commissioning(path: Path, cell: str, tool: str) -> Commissioning:
    """The commissioning record in `path` (a run's commissioning.json), checked to be of
    `cell` and to hold complete readings of `tool`; ScenarioError saying what to change."""
    try:
        record = structure(json.loads(Path(path).read_text(encoding="utf-8")), Commissioning)
    except (OSError, ValueError, KeyError, TypeError, BaseValidationError) as exc:
        raise ScenarioError(
            f"--commissioning {path}: not a commissioning record ({exc}); give a run's "
            f"{COMMISSIONING_FILE}"
        ) from None
    if record.cell != cell:
        raise ScenarioError(
            f"--commissioning {path} is the record of the cell {record.cell!r}; this job's "
            f"cell is {cell!r}: give that cell's record, or leave --commissioning out to "
            "commission the cell now"
        )
    if not record.readings(tool):
        tools = sorted({r.tool for r in record.references})
        raise ScenarioError(
            f"--commissioning {path} holds no complete reading of the {tool} (it has "
            f"{', '.join(tools) or 'none'}): leave --commissioning out to commission it now"
        )
    return record


class Commissioner:
    """The job's real cell as it was commissioned, made when a stage first asks: the job's
    tool read at the beam on a copy of the cell without the job's faults or its recording,
    moving with the arm's model the job's controller moves with then (a cell is
    commissioned with the calibration it runs on; its cell time is not the job's); across
    the network, on the cell itself, now. Or the record `given` (read_commissioning). Written
    to the run's commissioning.json."""

    def __init__(
        self,
        config: JobConfig,
        plan: JobPlan,
        job: JobRun,
        say: Progress,
        given: Path | None = None,
    ) -> None:
        self._config, self._plan, self._job, self._say = config, plan, job, say
        self._given = given
        self._record: Commissioning | None = None

    def __call__(self) -> Commissioning | None:
        config, plan, job = self._config, self._plan, self._job
        tool = config.operations.tool
        if not config.verify.tool_reference or tool not in POINTERS:
            return None
        if self._record is None:
            t0 = time.perf_counter()
            name = cell_label(plan.robot.name, config.seed)
            if self._given is not None:
                self._record = read_commissioning(self._given, name, tool)
                made = f"from {self._given}"
            else:
                self._record = commission(self._cell(), (tool,), name)
                made = "at the beam"
            write_json(job.folder / COMMISSIONING_FILE, unstructure(self._record))
            job.timings["commissioning"] = time.perf_counter() - t0
            self._say(
                f"the cell's commissioning: the {tool} read {len(self._record.references)} "
                f"times {made}"
            )
        return self._record

    def _cell(self) -> Controller:
        """The cell the commissioning reads the tool in."""
        config, plan, job = self._config, self._plan, self._job
        if job.cell.evaluator is None:
            return job.cell.controller  # across the network: the cell itself, now
        copy = build_job_cell(config, plan.virtual, plan.real, plan.robot).controller
        copy.set_absolute_accuracy(job.cell.controller.absolute_accuracy)
        return copy
