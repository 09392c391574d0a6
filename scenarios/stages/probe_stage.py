"""The probing: the part's edges found with the IR sensor (scenarios.offline.probing), a
pose of the part in the nominal table frame."""

from __future__ import annotations

from dataclasses import dataclass

from scenarios.offline.probing import probe_part
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome
from scenarios.stages.state import JobState, LocatedPose


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


@dataclass(frozen=True)
class Probed(Outcome):
    """The probing's pose."""

    pose: LocatedPose

    def advance(self, state: JobState) -> JobState:
        return state.with_pose(self.pose)


@dataclass(frozen=True)
class Probe:
    """The stage "probe": quick, and the prior of a surface match in mode "refine"."""

    name: str = "probe"
    title: str = "the part's edges with the IR sensor"

    def due(self, ctx: StageContext) -> bool:
        return True

    def run(self, ctx: StageContext) -> Probed:
        return Probed(probe_stage(ctx))
