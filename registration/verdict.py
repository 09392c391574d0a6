"""The verdict on a registration, for the whole model and for each target.

A pose is accepted only if it fits (RMS, inlier fraction), nothing else fits as well and
moves what matters, and the pose is constrained well enough. What matters is the targets
the caller names (the operation's entry points, say); with none named, the whole model:
- a symmetry of the model that moves a target makes that target ambiguous, however good
  the fit: the data cannot tell the symmetric poses apart;
- a rival minimum (a distinct pose that fits almost as well) makes ambiguous the targets
  it moves by more than the tolerance;
- a target whose predicted TRE exceeds the limit is ambiguous: the pose is poorly
  constrained there.
Targets that the symmetries and the rival leave in place, within the tolerance, are located
as well as their predicted TRE says.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from registration.rigid import Array, transform_points
from registration.symmetry import Symmetry

Verdict = Literal["accepted", "ambiguous", "rejected"]


@dataclass(frozen=True)
class Acceptance:
    """Thresholds of the verdict.

    Attributes:
        max_rms: largest acceptable inlier RMS [length units]; None: 1 % of the model extent.
        min_inlier_fraction: smallest acceptable fraction of data points that fit.
        min_surface_fit: smallest acceptable fraction of the scan's surface points near the
            model (those not scattered in space, by the data's own density and flatness,
            within the matcher's reach of the model) that fit: a right pose of the right
            object fits nearly all of them, another object's scan placed on the model
            leaves a part of its surface a few millimetres off. Lower it for scans that
            hold other surfaces than the object's close to it.
        max_ambiguity: largest acceptable ratio of best to second-best distinct minimum cost.
        max_predicted_tre: largest acceptable predicted TRE [length units], over the model
            surface or at the targets; None: 2 % of the model extent. It is also the
            tolerance: a symmetry or a rival pose that moves a target by less is harmless.
    """

    max_rms: float | None = None
    min_inlier_fraction: float = 0.5
    min_surface_fit: float = 0.9
    max_ambiguity: float = 0.5
    max_predicted_tre: float | None = None

    def rms_limit(self, extent: float) -> float:
        """max_rms, resolved for a model of this extent [length units]."""
        return self.max_rms if self.max_rms is not None else 0.01 * extent

    def tre_limit(self, extent: float) -> float:
        """max_predicted_tre, resolved for a model of this extent [length units]."""
        return self.max_predicted_tre if self.max_predicted_tre is not None else 0.02 * extent


@dataclass(frozen=True)
class Rival:
    """A distinct pose judged against the best.

    Attributes:
        motion: T_model_model (4, 4) that takes the best pose, as it was judged, to the
            rival's (T_rival = motion @ T_best); measured before the final refinement,
            which may carry the best further along a valley of the cost.
        ambiguity: the ratio of their costs in [0, 1] (1: they fit alike).
    """

    motion: Array
    ambiguity: float


@dataclass(frozen=True)
class TargetPrediction:
    """What a registration says about each of K targets given in the model frame.

    Attributes:
        tre: predicted target registration error (K,) [length units].
        moved_by: per target, what moves it by more than the tolerance although it fits as
            well (a symmetry of the model or a rival minimum), in words; None if nothing.
        verdict: per target, "accepted", "ambiguous" or "rejected".
        reason: per target, why, in words.
    """

    tre: Array
    moved_by: tuple[str | None, ...]
    verdict: tuple[Verdict, ...]
    reason: tuple[str, ...]

    @property
    def all_accepted(self) -> bool:
        """True if every target is accepted."""
        return all(v == "accepted" for v in self.verdict)


def fit_rejection(
    rms: float, inlier_fraction: float, surface_fit: float, extent: float, acceptance: Acceptance
) -> str | None:
    """Why the fit itself is rejected, or None if it is good enough."""
    if inlier_fraction < acceptance.min_inlier_fraction:
        return (
            f"only {inlier_fraction:.0%} of the data fit the model "
            f"(needs {acceptance.min_inlier_fraction:.0%})"
        )
    if surface_fit < acceptance.min_surface_fit:
        return (
            f"only {surface_fit:.0%} of the scan's surface points fit the model (needs "
            f"{acceptance.min_surface_fit:.0%}): a part of the scanned surface is not the model's"
        )
    limit = acceptance.rms_limit(extent)
    if rms > limit:
        return f"inlier RMS {rms:.3g} exceeds {limit:.3g}"
    return None


def model_verdict(
    fit_reason: str | None,
    symmetries: Sequence[Symmetry],
    ambiguity: float,
    worst_tre: float,
    searched: bool,
    extent: float,
    acceptance: Acceptance,
) -> tuple[Verdict, str]:
    """The verdict for the whole model (no targets named) and the reason for it."""
    if fit_reason is not None:
        return "rejected", fit_reason
    if symmetries:
        names = "; ".join(s.name for s in symmetries[:3])
        more = f" and {len(symmetries) - 3} more" if len(symmetries) > 3 else ""
        return "ambiguous", (
            f"the model is symmetric ({names}{more}): poses that differ by it fit exactly "
            f"alike; name the targets that matter"
        )
    if ambiguity > acceptance.max_ambiguity:
        return "ambiguous", (
            f"a distinct pose fits almost as well (ambiguity {ambiguity:.2f} > "
            f"{acceptance.max_ambiguity:.2f})"
        )
    limit = acceptance.tre_limit(extent)
    if worst_tre > limit:
        return "ambiguous", (
            f"the pose is poorly constrained: predicted TRE up to {worst_tre:.3g} "
            f"(limit {limit:.3g})"
        )
    if not searched:
        return (
            "accepted",
            "good fit, well-constrained pose (refined from T_init: no rival searched)",
        )
    return "accepted", "good fit, unique minimum, well-constrained pose"


def assess_targets(
    targets: Array,
    tre: Array,
    fit_reason: str | None,
    symmetries: Sequence[Symmetry],
    rivals: Sequence[Rival],
    extent: float,
    acceptance: Acceptance,
) -> TargetPrediction:
    """Per-target verdicts.

    Args:
        targets: (K, 3) in the model frame.
        tre: their predicted TRE (K,).
        rivals: the distinct poses judged against the best; each that fits almost as well
            (ambiguity above the limit) makes ambiguous the targets it moves.
    """
    tolerance = acceptance.tre_limit(extent)
    moved: list[str | None] = [None] * len(targets)
    verdicts: list[Verdict] = []
    reasons: list[str] = []
    for symmetry in symmetries:
        shift = symmetry.displacement(targets)
        for k in map(int, np.flatnonzero(shift > tolerance)):
            moved[k] = moved[k] or f"the model's {symmetry.name} (moves it {shift[k]:.3g})"
    for rival in rivals:
        if rival.ambiguity <= acceptance.max_ambiguity:
            continue
        shift = np.linalg.norm(transform_points(rival.motion, targets) - targets, axis=1)
        for k in map(int, np.flatnonzero(shift > tolerance)):
            moved[k] = moved[k] or (
                f"a distinct pose that fits almost as well (ambiguity {rival.ambiguity:.2f}, "
                f"moves it {shift[k]:.3g})"
            )
    for k in range(len(targets)):
        if fit_reason is not None:
            verdicts.append("rejected")
            reasons.append(fit_reason)
        elif moved[k] is not None:
            verdicts.append("ambiguous")
            reasons.append(f"ambiguous: {moved[k]}")
        elif tre[k] > tolerance:
            verdicts.append("ambiguous")
            reasons.append(
                f"poorly constrained: predicted TRE {tre[k]:.3g} (limit {tolerance:.3g})"
            )
        else:
            verdicts.append("accepted")
            reasons.append(f"located: predicted TRE {tre[k]:.3g}")
    return TargetPrediction(
        np.asarray(tre, dtype=float), tuple(moved), tuple(verdicts), tuple(reasons)
    )
