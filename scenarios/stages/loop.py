"""The one loop that runs a job's stages (scenarios.stages.stage): each due stage is entered,
run on the context, and its outcome moves the job's state on; an outcome may put stages
before the rest (the verification's re-scan). The controller's supervision may stop the cell
in any stage: the loop then ends there, and says so."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

from cell.cell_errors import SupervisionError
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome, Stage
from scenarios.stages.state import JobState


@dataclass(frozen=True, eq=False)
class StagesRun:
    """How a job's stages ended: the job's `state`, and the supervision's stop if one ended
    them early (`aborted`, in the stage `stopped_in`)."""

    state: JobState
    aborted: SupervisionError | None = None
    stopped_in: str | None = None


def run_stages(
    stages: Sequence[Stage],
    ctx: StageContext,
    enter: Callable[[Stage, JobState], None],
    saw: Callable[[Stage, Outcome, JobState], None],
) -> StagesRun:
    """Run `stages` in order on `ctx`: `enter(stage, state)` as each due stage begins,
    `saw(stage, outcome, state)` as it ends, with the state it left."""
    queue = deque(stages)
    while queue:
        stage = queue.popleft()
        if not stage.due(ctx):
            continue
        enter(stage, ctx.state)
        try:
            outcome = stage.run(ctx)
        except SupervisionError as stop:
            return StagesRun(ctx.state, stop, stage.name)
        ctx = replace(ctx, state=outcome.advance(ctx.state))
        saw(stage, outcome, ctx.state)
        queue.extendleft(reversed(outcome.then()))
    return StagesRun(ctx.state)
