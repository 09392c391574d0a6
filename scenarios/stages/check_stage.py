"""The corrected programs: the operations (and the pick) planned on the localized pose,
with the controller's kinematics, and checked in the virtual cell before they move."""

from __future__ import annotations

from dataclasses import dataclass, replace

from scenarios.offline.cell_model import CellModel
from scenarios.offline.job_cell import job_virtual_cell
from scenarios.offline.operations import grasp_operation, program_operations, target_operations
from scenarios.offline.premotion import check_program
from scenarios.offline.premotion_verdict import PremotionCheck, PremotionLimits
from scenarios.offline.program_plan import plan_program
from scenarios.offline.program_proposal import Findings, propose_changes
from scenarios.offline.table_candidates import UnreachablePlanError
from scenarios.program.program_types import OfflineProgram, Operation
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome
from scenarios.stages.state import JobState, LocatedPose, ProgramStage


def program_stage(
    ctx: StageContext, poses: tuple[LocatedPose, ...], model: CellModel
) -> ProgramStage:
    """Correct and solve the operations with the first method's pose (and, with
    `per_method`, once with each accepted method's pose), and the pick before them. A
    user's program keeps its poses (no spin about the tool axis) and its table position."""
    controller, virtual, user = ctx.controller, ctx.virtual, ctx.user
    section = ctx.settings.operations
    kin = controller.kinematics
    pick = None
    if section.pick is not None and poses[0].T_table_object is not None:
        pick = plan_program(
            kin.for_tool("gripper"),
            controller.T_flange_tcp("gripper"),
            "gripper",
            (grasp_operation(virtual, section.pick),),
            poses[0].T_table_object,
            controller.read_joints(),
            spins=2,
            table=model.T_base_table,
        )
    if user is None:
        operations = target_operations(virtual, section)
        spins, table = section.spins, None
    else:
        operations, spins, table = program_operations(user), 1, (user.table_position_m,)
    programs: dict[str, OfflineProgram] = {}
    for pose in poses if section.per_method else poses[:1]:
        if pose.T_table_object is None or not pose.accepted:
            continue
        prefix = f"{pose.method}:" if section.per_method else ""
        programs[pose.method] = plan_program(
            kin.for_tool(section.tool),
            controller.T_flange_tcp(section.tool),
            section.tool,
            tuple(replace(op, name=prefix + op.name) for op in operations),
            pose.T_table_object,
            controller.read_joints(),
            spins,
            **({} if table is None else {"table_positions": table}),
            table=model.T_base_table,
            joint_margin_rad=PremotionLimits().joint_margin_rad,
        )
    return ProgramStage(pick, programs)


def check_stage(ctx: StageContext, programs: ProgramStage) -> PremotionCheck | None:
    """Each corrected program followed in the virtual cell before it moves
    (scenarios.offline.premotion), the object at the pose the program was corrected with;
    the first check that fails, or None. The pick is not checked: its part moves with the
    gripper."""
    controller, settings = ctx.controller, ctx.settings
    for program in programs.operations.values():
        cell = job_virtual_cell(
            controller.robot,
            settings.rack_xyz,
            ctx.virtual,
            program.T_table_object,
            settings.calibration.enabled,
            settings.object_name,
        )
        check = check_program(
            program,
            controller.kinematics,
            cell,
            controller.q_home,
            controller.T_flange_tcp(program.tool),
            object_name=settings.object_name,
        )
        if not check.ok:
            return check
    return None


def program_proposal(ctx: StageContext, programs: ProgramStage, check: PremotionCheck) -> str:
    """What to change in a user's program the virtual cell refused (scenarios.offline.
    program_proposal): "; proposed: ..." with each refused touch's change and the poses to
    write, checked the way the program was; "" for a job's own program (its touches already
    tried every spin) or where no change lets it pass."""
    program = next(iter(programs.operations.values()), None)
    if ctx.user is None or program is None:
        return ""
    controller, settings = ctx.controller, ctx.settings
    cell = job_virtual_cell(
        controller.robot, settings.rack_xyz, ctx.virtual, program.T_table_object,
        settings.calibration.enabled, settings.object_name,
    )  # fmt: skip
    kin = controller.kinematics.for_tool(program.tool)
    T_tcp = controller.T_flange_tcp(program.tool)

    def refused(operations: tuple[Operation, ...]) -> Findings:
        try:
            trial = plan_program(
                kin, T_tcp, program.tool, operations, program.T_table_object,
                controller.q_home, 1, (program.table_position_m,),
                table=ctx.state.model.T_base_table,
                joint_margin_rad=PremotionLimits().joint_margin_rad,
            )  # fmt: skip
        except UnreachablePlanError as exc:
            return {op.name: [str(exc)] for op in operations}
        verdict = check_program(trial, controller.kinematics, cell, controller.q_home, T_tcp,
                                object_name=settings.object_name)  # fmt: skip
        findings: Findings = {}
        for problem in verdict.problems:
            findings.setdefault(problem.move.split(":")[0], []).append(problem.detail)
        return findings

    proposal = propose_changes(program_operations(ctx.user), refused)
    return "" if proposal is None else "; proposed: " + proposal.text()


@dataclass(frozen=True)
class Checked(Outcome):
    """The corrected programs, or the check that refused them (then the pose of `method`
    is no longer accepted)."""

    programs: ProgramStage
    method: str
    refusal: PremotionCheck | None = None
    proposal: str = ""

    def advance(self, state: JobState) -> JobState:
        if self.refusal is not None:
            return state.refused(self.method, self.refusal.summary + self.proposal, "check")
        return replace(state, programs=self.programs)


@dataclass(frozen=True)
class Check:
    """The stage "check": the programs corrected with the accepted pose, each followed in
    the virtual cell before it moves; due only if the pose that drives them is accepted."""

    name: str = "check"
    title: str = "the corrected program, planned and followed in the virtual cell"

    def due(self, ctx: StageContext) -> bool:
        return ctx.state.primary(ctx.settings.localization.methods).accepted

    def run(self, ctx: StageContext) -> Checked:
        methods = ctx.settings.localization.methods
        programs = program_stage(ctx, ctx.state.ordered(methods), ctx.state.model)
        check = check_stage(ctx, programs)
        if check is None:
            ctx.hooks.say("check: the corrected program passes in the virtual cell")
            return Checked(programs, methods[0])
        proposal = program_proposal(ctx, programs, check)
        ctx.hooks.detect("premotion", check.summary + proposal, "refused")
        return Checked(programs, methods[0], check, proposal)
