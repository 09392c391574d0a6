"""The execution of the corrected programs on the real cell: the pick, then each program
with its tool checked at the beam first (scenarios.offline.tcp_check)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller
from scenarios.offline.error_budget import error_budget, local_model_error, tool_term
from scenarios.offline.pick import execute_pick
from scenarios.offline.program_plan import execute_program
from scenarios.offline.settings import PlanningSettings
from scenarios.offline.tcp_check import TOLERANCE_M, check_tcp, checked_tool
from scenarios.results.budget_result import ErrorBudget
from scenarios.results.verification_result import TcpCheck
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome
from scenarios.stages.state import ProgramStage

#: The least tolerance a goal leaves a tool [m]: a pointer's own manufacturing tolerance
#: (ISO 2768-f over its 0.2 m, +-0.15 mm as three standard deviations).
MIN_TOLERANCE_M = 5.0e-5


def tool_tolerance(settings: PlanningSettings) -> float:
    """How far off where it should sit a tool may be [m]: `verify.tool_tolerance_m` if given,
    else what the job's RMS goal leaves for it: an offset of the tool moves every target
    alike, so it adds to the error the job plans for (the scan's TRE goal and the arm's
    accuracy in quadrature) in the worst case; TOLERANCE_M without a goal."""
    given = settings.verify.tool_tolerance_m
    if given is not None:
        return given
    if settings.goal_rms_m is None:
        return TOLERANCE_M
    planned = math.hypot(
        settings.localization.scan.planning.goal_tre_m, settings.verify.arm_accuracy_m
    )
    return max(settings.goal_rms_m - planned, MIN_TOLERANCE_M)


def tool_check(ctx: StageContext, tool: str) -> Callable[[Controller, int], TcpCheck | None]:
    """The check of `tool` at the beam as the job makes it: against the job's tolerance,
    differenced against the cell's commissioning readings of the tool if it has some, its
    uncertainty's floors from the data sheets (`verify`)."""
    verify = ctx.settings.verify
    record = ctx.hooks.commissioning() if verify.tool_reference else None
    references = () if record is None else record.readings(tool)
    tolerance = tool_tolerance(ctx.settings)

    def check(controller: Controller, attempt: int) -> TcpCheck | None:
        priors = (verify.repeatability_m, verify.arm_accuracy_m)
        return check_tcp(controller, tolerance, attempt, references, priors)

    return check


def budget(ctx: StageContext, check: TcpCheck | None) -> ErrorBudget | None:
    """The error budget of the targets of the program the surface pose drives
    (scenarios.offline.error_budget), its tool's last `check` in it; None without such a pose."""
    state = ctx.state
    pose, scanned = state.pose("surface"), state.scanned
    if pose is None or pose.localization is None or pose.T_table_object is None:
        return None
    if scanned is None or not ctx.virtual.burr_holes:
        return None
    holes = ctx.virtual.burr_holes
    targets = np.array([h.p_entry for h in holes])
    tre = pose.localization.result.predicted_tre(targets).tre
    local = local_model_error(ctx.virtual, pose.T_table_object, scanned.points_table, targets)
    calibration = state.calibration
    residual = None if calibration is None else calibration.residual_rms_after_m
    kept = None if calibration is None or calibration.check is None else calibration.check
    return error_budget(
        tuple(h.name for h in holes),
        np.asarray(tre, float),
        local,
        tool_term(check, tool_tolerance(ctx.settings)),
        residual,
        ctx.settings,
        None if kept is None else kept.kept_error_m,
    )


def execute_stage(ctx: StageContext, programs: ProgramStage) -> tuple[TcpCheck, ...]:
    """Run the pick, then each program: the program's tool taken and checked at the beam,
    the error budget of the program the surface pose drives told to the run, then at each
    target the tool stops at the touch (and the screwer spins for `screw`). Returns the
    tools' checks."""
    controller, hooks = ctx.controller, ctx.hooks
    section = ctx.settings.operations
    if programs.pick is not None and section.pick is not None:
        execute_pick(controller, programs.pick, section.pick, hooks)
    checks: list[TcpCheck] = []
    for method, program in programs.operations.items():
        check = tool_check(ctx, program.tool)
        made = checked_tool(controller, program.tool, hooks.say, hooks.detect, hooks.checked, check)
        checks += made
        if method == "surface":
            budgeted = budget(ctx, made[-1] if made else None)
            if budgeted is not None:
                hooks.say(budgeted.summary())
                hooks.budgeted(budgeted)

        def at_target(name: str) -> None:
            hooks.moment(name, section.tool)
            if section.kind == "screw":
                controller.spin_screwer(section.screw_speed_rad_s, section.screw_s)

        T_flange_tcp = None
        if made and made[-1].corrected:  # the seat's shift the beam measured
            T_flange_tcp = controller.T_flange_tcp(program.tool) @ made[-1].T_tcp_measured
        execute_program(controller, program, section.touch_speed_m_s, on_touch=at_target,
                        on_move=hooks.moved, T_flange_tcp=T_flange_tcp)  # fmt: skip
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
