"""The execution of the corrected programs on the real cell: the pick, then each program
with its tool checked at the beam first (scenarios.offline.tcp_check)."""

from __future__ import annotations

from dataclasses import dataclass

from scenarios.offline.pick import execute_pick
from scenarios.offline.program import execute_program
from scenarios.offline.tcp_check import checked_tool
from scenarios.stages.context import StageContext
from scenarios.stages.program import ProgramStage
from scenarios.stages.stage import Outcome


def execute_stage(ctx: StageContext, programs: ProgramStage) -> None:
    """Run the pick, then each program: the program's tool taken and checked at the beam,
    then at each target the tool stops at the touch (and the screwer spins for `screw`)."""
    controller, hooks = ctx.controller, ctx.hooks
    section = ctx.settings.operations
    if programs.pick is not None and section.pick is not None:
        execute_pick(controller, programs.pick, section.pick, hooks)
    for method, program in programs.operations.items():
        checked_tool(controller, program.tool, hooks.say, hooks.detect)

        def at_target(name: str) -> None:
            hooks.moment(name, section.tool)
            if section.kind == "screw":
                controller.spin_screwer(section.screw_speed_rad_s, section.screw_s)

        execute_program(
            controller, program, section.touch_speed_m_s, on_touch=at_target, on_move=hooks.moved
        )
        hooks.say(
            f"{method}: {len(program.operations)} operations at table {program.table_position_m} m"
        )


@dataclass(frozen=True)
class Executed(Outcome):
    """The corrected programs ran on the real cell (what they achieved is the evaluator's
    to say)."""


@dataclass(frozen=True)
class Execute:
    """The stage "execute": due if the pose that drives the programs is accepted and there
    are programs to run."""

    title: str = "the corrected program"
    name: str = "execute"

    def due(self, ctx: StageContext) -> bool:
        state = ctx.state
        return state.primary(ctx.settings.localization.methods).accepted and bool(
            state.programs.operations
        )

    def run(self, ctx: StageContext) -> Executed:
        execute_stage(ctx, ctx.state.programs)
        return Executed()
