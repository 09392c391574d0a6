"""The targets' error budget in the recording, logged when it is made (before the first touch):
each target's bound in mm as bars (`plots/budget/bound_mm`, in the targets' order) and one
log line with the bounds against the goals, a warning when a goal is at risk."""

from __future__ import annotations

import numpy as np
import rerun as rr

from scenarios.realcell.recording.stream import Stream
from scenarios.results.budget_result import ErrorBudget

WITHIN_REACH = (40, 200, 60)
AT_RISK = (255, 150, 0)


def log_budget(stream: Stream, time_s: float, budget: ErrorBudget) -> None:
    """`budget` at `time_s` [s] of the cell's clock."""
    stream.at(sim_time=time_s)
    bounds = np.array([t.bound_m for t in budget.targets]) * 1e3
    colour = WITHIN_REACH if budget.within_reach else AT_RISK
    stream.log(
        "plots/budget/bound_mm", rr.BarChart(np.nan_to_num(bounds, posinf=0.0), color=list(colour))
    )
    names = ", ".join(t.name for t in budget.targets)
    level = "INFO" if budget.within_reach else "WARN"
    stream.log("log", rr.TextLog(f"{budget.summary()} ({names})", level=level))
