"""The verification before the first touch: a strip of the object scanned again at the
program's table position, matched on its own, the targets it places compared with the
registration's (scenarios.offline.verify)."""

from __future__ import annotations

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
