"""The execution of the corrected programs on the real cell: the pick, then each program
with its tool checked at the beam first (scenarios.offline.tcp_check)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from scenarios.offline.pick import execute_pick
from scenarios.offline.program import execute_program
from scenarios.offline.settings import PlanningSettings
from scenarios.offline.tcp_check import TOLERANCE_M, checked_tool
from scenarios.results.verification import TcpCheck
from scenarios.stages.context import StageContext
from scenarios.stages.program import ProgramStage
from scenarios.stages.stage import Outcome


def tool_tolerance(settings: PlanningSettings) -> float:
    """How far off its tooldata a tool may sit [m]: `verify.tool_tolerance_m` if given, else
    what the job's RMS goal leaves for it (an offset of the tool moves every target alike,
    in any direction: the goal less the error the job plans for, the scan's TRE goal and
    the arm's accuracy in quadrature), but at least what the check reads on a well seated
    tool (twice the arm's accuracy: the check's reading holds the tool's own TCP error and
    what the arm's error changes between two opposite turns of its wrist); TOLERANCE_M
    without a goal."""
    given = settings.verify.tool_tolerance_m
    if given is not None:
        return given
    if settings.goal_rms_m is None:
        return TOLERANCE_M
    planned = math.hypot(
        settings.localization.scan.planning.goal_tre_m, settings.verify.arm_accuracy_m
    )
    return max(settings.goal_rms_m - planned, 2.0 * settings.verify.arm_accuracy_m)


def execute_stage(ctx: StageContext, programs: ProgramStage) -> tuple[TcpCheck, ...]:
    """Run the pick, then each program: the program's tool taken and checked at the beam,
    then at each target the tool stops at the touch (and the screwer spins for `screw`).
    Returns the tools' checks."""
    controller, hooks = ctx.controller, ctx.hooks
    section = ctx.settings.operations
    if programs.pick is not None and section.pick is not None:
        execute_pick(controller, programs.pick, section.pick, hooks)
    tolerance = tool_tolerance(ctx.settings)
    checks: list[TcpCheck] = []
    for method, program in programs.operations.items():
        checks += checked_tool(controller, program.tool, hooks.say, hooks.detect, tolerance)

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
    return tuple(checks)


@dataclass(frozen=True)
class Executed(Outcome):
    """The corrected programs ran on the real cell (what they achieved is the evaluator's
    to say), their tools checked at the beam (`tool_checks`)."""

    tool_checks: tuple[TcpCheck, ...] = ()


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
        return Executed(execute_stage(ctx, ctx.state.programs))
