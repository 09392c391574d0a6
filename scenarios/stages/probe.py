"""The probing: the part's edges found with the IR sensor (scenarios.offline.probing), a
pose of the part in the nominal table frame."""

from __future__ import annotations

from scenarios.offline.probing import probe_part
from scenarios.stages.context import StageContext
from scenarios.stages.register import LocatedPose


def probe_stage(ctx: StageContext) -> LocatedPose:
    """Probe the virtual model's probe lines on the real part; the pose it gives."""
    probed = probe_part(
        ctx.controller,
        ctx.virtual.probe_lines,
        ctx.T_table_nominal,
        ctx.settings.localization.probe.height_m,
        progress=ctx.hooks.say,
    )
    return LocatedPose("probe", probed.T_table_object, True, "", probe=probed)
