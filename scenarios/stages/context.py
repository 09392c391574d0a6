"""What a stage is handed: the controller, the virtual model, its planning settings, the job
so far.

A stage sees the real cell as a program on a real controller would, through the controller
API (cell.controller), and knows of the job what its planning settings tell
(scenarios.offline.settings.PlanningSettings). The context holds nothing else: not the
simulation, not the truth, not the evaluator, not the real cell's noise, faults or the
ranges its placement is drawn from. The runner builds it once the real cell stands.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell import Controller
from models.model import ObjectModel
from scenarios.offline.hooks import StageHooks
from scenarios.offline.operations import UserProgram
from scenarios.offline.scan_passes import ObjectBox
from scenarios.offline.settings import PlanningSettings
from scenarios.stages.state import JobState


@dataclass(frozen=True, eq=False)
class StageContext:
    """A stage's view of the job: the `controller` (the real cell's API), the `virtual`
    model with its targets, where the planner believes it sits (`T_table_nominal` (4, 4),
    its footprint `box`), the user's program if the job runs one, the planning `settings`,
    the `hooks` into the run, the folder the job's outputs go to, the `state` of the job
    so far (what the earlier stages found)."""

    controller: Controller
    virtual: ObjectModel
    T_table_nominal: np.ndarray
    box: ObjectBox
    settings: PlanningSettings
    hooks: StageHooks
    state: JobState
    folder: Path
    user: UserProgram | None = None
