"""The verification before the first touch: strips of the object scanned again as they were
scanned, the object's move since the scan measured at each target and held to what the
job's goal leaves (scenarios.offline.verification)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from scenarios.offline.cell_model import CellModel
from scenarios.offline.settings import Registration
from scenarios.offline.verification import (
    Budget,
    RegisteredTargets,
    Rescanned,
    ScanRecord,
    Verification,
    allowances,
    verify_registration,
)
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome, Stage
from scenarios.stages.state import JobState, LocatedPose, ProgramStage, ScanStage

#: The arm's accuracy per axis [m] when the job does not tell the matcher (the configuration's
#: default, a data sheet's 0.3 mm in all): the verification needs it.
PASS_SIGMA_M = float(Registration().pass_sigma_m or 0.0)


def verify_stage(
    ctx: StageContext,
    pose: LocatedPose,
    scanned: ScanStage,
    programs: ProgramStage,
    model: CellModel,
) -> Rescanned:
    """Scan strips of the object again and measure how far it moved since the surface
    match's `pose` was found, at each target, against what the job's goal leaves."""
    assert pose.localization is not None and pose.T_table_object is not None
    settings, virtual = ctx.settings, ctx.virtual
    program = next(iter(programs.operations.values()))
    section = settings.verify
    pass_sigma = settings.localization.registration.pass_sigma_m
    targets = tuple((h.name, h.p_entry) for h in virtual.burr_holes)
    tre = pose.localization.result.predicted_tre(np.array([p for _, p in targets])).tre
    rescanned = verify_registration(
        ctx.controller,
        virtual,
        RegisteredTargets(
            pose.T_table_object,
            targets,
            tre,
            allowances(settings.goal_rms_m, tre, section.arm_accuracy_m),
        ),
        ScanRecord(scanned.scan, scanned.keep, scanned.plan),
        ctx.box,
        settings.localization.scan,
        program.table_position_m,
        model,
        Budget(
            settings.goal_rms_m,
            settings.localization.scan.planning.range_sigma_m,
            section.repeatability_m,
            PASS_SIGMA_M if pass_sigma is None else pass_sigma,
            section.max_strips,
            section.arm_accuracy_m,
        ),
        ctx.hooks.say,
    )
    verdict = rescanned.verification
    ctx.hooks.say(f"verify: {'agrees' if verdict.agrees else 'DISAGREES'}: {verdict.summary()}")
    return rescanned


@dataclass(frozen=True, eq=False)
class Verified(Outcome):
    """The verification's verdict, the pose it verified (T_table_object (4, 4) [m]) and the
    strips' points (N, 3) [m] in the table frame. If it disagrees, the stages `rescan` run
    again and the verification after them; on the last attempt the surface pose is refused
    instead."""

    verification: Verification
    T_table_object: np.ndarray
    strip_table: np.ndarray
    rescan: tuple[Stage, ...] = ()
    refusal: str | None = None

    def advance(self, state: JobState) -> JobState:
        if self.refusal is not None:
            return state.refused("surface", f"verification: {self.refusal}", "verify")
        return state

    def then(self) -> tuple[Stage, ...]:
        return self.rescan


@dataclass(frozen=True, eq=False)
class Verify:
    """The stage "verify", before any target is touched: if the object disagrees with the
    match, the `rescan` stages (scan, register, check) run again, then the verification
    once more (`attempt` counts from 0 of `attempts`); if it still disagrees, the job
    refuses. Due while there is a corrected program."""

    rescan: tuple[Stage, ...]
    attempt: int = 0
    attempts: int = 2
    name: str = "verify"
    title: str = "the object's move since the scan, measured on strips scanned again"

    def due(self, ctx: StageContext) -> bool:
        return bool(ctx.state.programs.operations)

    def run(self, ctx: StageContext) -> Verified:
        state = ctx.state
        pose, scanned = state.pose("surface"), state.scanned
        assert pose is not None and scanned is not None
        rescanned = verify_stage(ctx, pose, scanned, state.programs, state.model)
        verdict = rescanned.verification
        assert pose.T_table_object is not None
        seen = (verdict, pose.T_table_object, rescanned.points_table)
        if verdict.agrees:
            return Verified(*seen)
        message = f"the object disagrees with the match: {verdict.summary()}"
        if self.attempt + 1 >= self.attempts:
            ctx.hooks.detect("verification", message, "refused")
            return Verified(*seen, refusal=message)
        ctx.hooks.detect("verification", message, "re-scanned and matched again")
        return Verified(*seen, (*self.rescan, replace(self, attempt=self.attempt + 1)))
