"""The surface match of the scan to the virtual model (scenarios.offline.localization): a
pose with a verdict at the operation targets, and the scan's returns that lie off it."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from models.model import ObjectModel
from registration import Acceptance, MeshModel, transform_points
from scenarios.offline.localization import Localization, localize, scan_passes, stray_returns
from scenarios.offline.settings import PlanningSettings
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome
from scenarios.stages.state import JobState, LocatedPose

Progress = Callable[[str], None]

#: How far a surface match may lie from the IR probing's pose before the two disagree: about
#: the vertical [deg] and sideways at the model's centre [m]. On the assembly job each method
#: is within 0.25 deg and 0.4 mm of the truth (docs/benchmarks.md); a wrong match (the part
#: half a turn round, a fit on a feature's mirror image) lies tens of degrees or millimetres
#: away. The probe sees neither height nor tilt, which are not compared.
AGREE_DEG = 2.0
AGREE_M = 3.0e-3
#: A match again from the probe's pose that fits the scan within this factor of the first
#: match's RMS fits it as well: the scan cannot tell the two apart, and the probe decides.
SAME_FIT = 1.2


def acceptance(settings: PlanningSettings) -> Acceptance:
    """The match's acceptance thresholds of the job's registration settings."""
    r = settings.localization.registration
    return Acceptance(
        max_rms=r.max_rms_m,
        min_inlier_fraction=r.min_inlier_fraction,
        max_ambiguity=r.max_ambiguity,
        max_predicted_tre=r.max_predicted_tre_m,
    )


def surface_pose(
    points_table: np.ndarray,
    pass_labels: np.ndarray,
    virtual: ObjectModel,
    settings: PlanningSettings,
    prior: np.ndarray | None,
    say: Progress,
) -> LocatedPose:
    """Surface matching of the scan's object points (M, 3) [m] (nominal table frame), each
    labelled with its pass (M,), to the virtual model, with a verdict per operation target;
    too few object points refuse it. `prior` (4, 4) is the start of mode "refine" only."""
    section = settings.localization
    if len(points_table) < section.scan.min_points:
        reason = (
            f"the scan has {len(points_table)} object points, fewer than the "
            f"{section.scan.min_points} required (localization.scan.min_points)"
        )
        return LocatedPose("surface", None, False, reason)
    r = section.registration
    located = localize(
        points_table,
        MeshModel(virtual.mesh.vertices, virtual.mesh.faces),
        r.max_points,
        acceptance(settings),
        settings.seed,
        r.voxel_m,
        r.mode,
        prior,
        scan_passes(pass_labels, r.pass_sigma_m),
        targets_model=np.array([h.p_entry for h in virtual.burr_holes]),
    )
    m = located.result
    say(f"match: {m.verdict} (rms {m.rms * 1e3:.3f} mm, ambiguity {m.ambiguity:.2f}, "
        f"{m.seconds:.2f} s)")  # fmt: skip
    accepted = m.verdict == "accepted"
    return LocatedPose("surface", located.T_table_object, accepted, m.reason, localization=located)


def disagreement(
    T_a_table_object: np.ndarray, T_b_table_object: np.ndarray, centre_object: np.ndarray
) -> tuple[float, float]:
    """How far two poses of the object (4, 4, nominal table frame) lie apart as a 2D probe
    sees them: the heading about the vertical [deg] and the model's centre (3,) [m]
    sideways [m]."""

    def heading(T: np.ndarray) -> float:
        return float(np.arctan2(T[1, 0], T[0, 0]))

    turn = (heading(T_a_table_object) - heading(T_b_table_object) + np.pi) % (2 * np.pi) - np.pi
    a, b = (
        transform_points(T, centre_object[None])[0] for T in (T_a_table_object, T_b_table_object)
    )
    return float(np.degrees(abs(turn))), float(np.linalg.norm((a - b)[:2]))


def against_probe(
    pose: LocatedPose,
    T_probe_table_object: np.ndarray,
    rematch: Callable[[np.ndarray], LocatedPose],
    centre_object: np.ndarray,
    detect: Callable[[str, str, str], None],
) -> LocatedPose:
    """An accepted surface `pose` held against the IR probing's pose (4, 4): where they
    disagree (AGREE_DEG, AGREE_M), the scan is matched again from the probe's pose
    (`rematch(prior)`); that match is taken where it is accepted, agrees with the probe and
    fits the scan as well as the first (SAME_FIT: the scan cannot tell them apart, the probe
    does); otherwise the pose is refused, with both fits said."""
    assert pose.T_table_object is not None and pose.localization is not None

    def agrees(T_table_object: np.ndarray) -> bool:
        turn, shift = disagreement(T_table_object, T_probe_table_object, centre_object)
        return turn <= AGREE_DEG and shift <= AGREE_M

    if agrees(pose.T_table_object):
        return pose
    turn, shift = disagreement(pose.T_table_object, T_probe_table_object, centre_object)
    said = (
        f"the surface match lies {turn:.1f} deg and {shift * 1e3:.1f} mm from the IR probing's pose"
    )
    detect("match_disagrees", said, "matched again from the probe's pose")
    again = rematch(T_probe_table_object)
    first_rms = pose.localization.result.rms
    if again.accepted and again.localization is not None and again.T_table_object is not None:
        again_rms = again.localization.result.rms
        fits = (
            f"rms {again_rms * 1e3:.3f} mm from the probe's pose, {first_rms * 1e3:.3f} mm "
            "as first matched"
        )
        if agrees(again.T_table_object) and again_rms <= SAME_FIT * first_rms:
            reason = f"{again.reason}; {said}, and the scan fits the probe's as well ({fits})"
            return LocatedPose("surface", again.T_table_object, True, reason, again.localization)
        why = f"{said}, and matched from the probe's pose the scan fits worse ({fits})"
    else:
        why = f"{said}, and matched from the probe's pose it is not accepted: {again.reason}"
    return LocatedPose("surface", pose.T_table_object, False, why, pose.localization)


def stray_message(points_table: np.ndarray, virtual: ObjectModel, located: Localization) -> str:
    """What the match says of the scan's returns (M, 3) that lie off the matched model
    (spurious returns, or something else on the table), or "" if none do."""
    stray = stray_returns(
        points_table,
        MeshModel(virtual.mesh.vertices, virtual.mesh.faces),
        located.T_table_object,
        located.result.rms,
    )
    if not stray:
        return ""
    return (
        f"{stray} scan points ({100 * stray / len(points_table):.2f} %) lie off the matched "
        "model: spurious returns or something else on the table"
    )


@dataclass(frozen=True)
class Registered(Outcome):
    """The surface match's pose; the programs corrected with an earlier one are dropped."""

    pose: LocatedPose

    def advance(self, state: JobState) -> JobState:
        return state.with_pose(self.pose).without_programs()


@dataclass(frozen=True)
class Register:
    """The stage "register": the latest scan matched to the virtual model (from the
    probing's pose in mode "refine"); a refusal and the returns off the model are checks
    that speak."""

    name: str = "register"
    title: str = "the scan to the virtual model (its steps on the timeline icp)"

    def due(self, ctx: StageContext) -> bool:
        return ctx.state.scanned is not None

    def run(self, ctx: StageContext) -> Registered:
        scanned, hooks = ctx.state.scanned, ctx.hooks
        assert scanned is not None
        probed = ctx.state.pose("probe")
        prior = None if probed is None else probed.T_table_object
        labels = scanned.scan.line_pass[scanned.scan.line_index][scanned.keep]
        pose = surface_pose(
            scanned.points_table, labels, ctx.virtual, ctx.settings, prior, hooks.say
        )
        registration = ctx.settings.localization.registration
        if pose.accepted and prior is not None and registration.mode != "refine":
            refine = ctx.settings.model_copy(
                update={"localization": ctx.settings.localization.model_copy(
                    update={"registration": registration.model_copy(update={"mode": "refine"})}
                )}
            )  # fmt: skip

            def rematch(T_prior: np.ndarray) -> LocatedPose:
                return surface_pose(
                    scanned.points_table, labels, ctx.virtual, refine, T_prior, hooks.say
                )

            centre = np.asarray(ctx.virtual.mesh.vertices, dtype=float).mean(axis=0)
            pose = against_probe(pose, prior, rematch, centre, hooks.detect)
        if not pose.accepted:
            hooks.detect("match_refused", pose.reason, "refused")
        if pose.localization is not None:
            stray = stray_message(scanned.points_table, ctx.virtual, pose.localization)
            if stray:
                hooks.detect("scan_outliers", stray, "left out by the match")
        return Registered(pose)
