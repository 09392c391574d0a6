"""The verification before the first touch: a strip of the object scanned again at the
program's table position, matched on its own, the targets it places compared with the
registration's (scenarios.offline.verify)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from scenarios.offline.cell_model import CellModel
from scenarios.offline.settings import Registration
from scenarios.offline.verify import (
    RegisteredTargets,
    ScanRecord,
    Verification,
    verify_registration,
)
from scenarios.stages.context import StageContext
from scenarios.stages.program import ProgramStage
from scenarios.stages.register import LocatedPose
from scenarios.stages.scan import ScanStage
from scenarios.stages.stage import Outcome, Stage

if TYPE_CHECKING:
    from scenarios.stages.state import JobState

#: The arm's accuracy per axis [m] when the job does not tell the matcher (the configuration's
#: default, a data sheet's 0.3 mm in all): the verification needs it.
PASS_SIGMA_M = float(Registration().pass_sigma_m or 0.0)


def verify_stage(
    ctx: StageContext,
    pose: LocatedPose,
    scanned: ScanStage,
    programs: ProgramStage,
    model: CellModel,
) -> Verification:
    """Scan a strip of the object again at the first program's table position, match it on
    its own and compare where the two matches put the targets with the surface match's
    `pose`."""
    assert pose.localization is not None and pose.T_table_object is not None
    program = next(iter(programs.operations.values()))
    settings, virtual = ctx.settings, ctx.virtual
    pass_sigma = settings.localization.registration.pass_sigma_m
    targets = tuple((h.name, h.p_entry) for h in virtual.burr_holes)
    verdict = verify_registration(
        ctx.controller,
        virtual,
        RegisteredTargets(
            pose.T_table_object,
            targets,
            pose.localization.result.predicted_tre(np.array([p for _, p in targets])).tre,
        ),
        ScanRecord(scanned.scan, scanned.keep, scanned.plan),
        ctx.box,
        settings.localization.scan,
        program.table_position_m,
        model,
        PASS_SIGMA_M if pass_sigma is None else pass_sigma,
        ctx.hooks.say,
    )
    ctx.hooks.say(f"verify: {'agrees' if verdict.agrees else 'DISAGREES'}: {verdict.summary()}")
    return verdict


@dataclass(frozen=True, eq=False)
class Verified(Outcome):
    """The verification's verdict. If it disagrees, the stages `rescan` run again and the
    verification after them; on the last attempt the surface pose is refused instead."""

    verification: Verification
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
    title: str = "the match on patches of the object, away from the targets"

    def due(self, ctx: StageContext) -> bool:
        return bool(ctx.state.programs.operations)

    def run(self, ctx: StageContext) -> Verified:
        state = ctx.state
        pose, scanned = state.pose("surface"), state.scanned
        assert pose is not None and scanned is not None
        verdict = verify_stage(ctx, pose, scanned, state.programs, state.model)
        if verdict.agrees:
            return Verified(verdict)
        message = f"the object disagrees with the match: {verdict.summary()}"
        if self.attempt + 1 >= self.attempts:
            ctx.hooks.detect("verification", message, "refused")
            return Verified(verdict, refusal=message)
        ctx.hooks.detect("verification", message, "re-scanned and matched again")
        return Verified(verdict, (*self.rescan, replace(self, attempt=self.attempt + 1)))
