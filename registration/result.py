"""What `match` returns: the pose, its quality, the minima it was judged against, the
model's symmetries, and the verdict."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from registration.quality import predicted_tre
from registration.rigid import Array
from registration.symmetry import Symmetry
from registration.verdict import Acceptance, Rival, TargetPrediction, Verdict, assess_targets


@dataclass(frozen=True)
class Minimum:
    """A local minimum reached by a refined start.

    Attributes:
        T_model_data: (4, 4) pose.
        cost: RMS of the smallest residuals of the data subsample: as large a fraction as
            the best pose fits (between `trim` and 0.99) [length units].
    """

    T_model_data: Array
    cost: float


@dataclass(frozen=True, eq=False)
class SearchTrace:
    """How the search went, for a picture of it.

    Attributes:
        starts: (K, 4, 4) every initial state T_model_data; start_costs: (K,) its score
            (trimmed RMS distance of a coarse subsample) [length units].
        minima: (M, 4, 4) the starts that survived the screening, after the coarse ICP;
            minima_costs: (M,) their trimmed RMS [length units].
        best: (4, 4) the minimum that became the best pose, before its refinement.
    """

    starts: Array
    start_costs: Array
    minima: Array
    minima_costs: Array
    best: Array


@dataclass(frozen=True)
class MatchResult:
    """Result of `match`.

    Attributes:
        T_model_data: (4, 4) maps data coordinates into model coordinates.
        rms: RMS of the inlier residuals [length units].
        inlier_fraction: fraction of data points that fit the model (Tukey weight > 0).
        surface_fit: fraction of the scan's surface points (not scattered in space, off the
            sharp edges) within the reach of the model that fit it.
        sigma: robust standard deviation of a residual [length units].
        iterations: ICP iterations of the best refinement.
        converged: the best refinement met the stopping rule before the cap.
        history: RMS per iteration of the best refinement (iterations,).
        trajectory: pose per iteration of the best refinement (iterations, 4, 4).
        mode: "auto", "global", "local" or "refine".
        starts: initial states evaluated.
        rivals: the distinct poses judged against the best, each with its motion from the
            best and its ambiguity; the verdict per target looks at every one.
        best: the best minimum; second: the best minimum distinct from it (and not one of
            its symmetric twins), or None.
        ambiguity: best cost / second cost in [0, 1], both with the floor added in
            quadrature; 0 if no other minimum was found or the other leaves clearly more of
            the scan unexplained, near 1 if two distinct poses fit equally well.
        covariance: (6, 6) covariance of (dt, dtheta) applied in the model frame.
        worst_predicted_tre: largest predicted TRE over the model surface [length units].
        symmetries: the model's symmetries (within the floor): poses that differ from the
            best by one of them fit exactly as well.
        equivalent_poses: the poses the discrete symmetries make of the best, S @ T (4, 4).
        floor: the smallest residual scale the data can resolve [length units]: the
            caller's stated noise, else the resolution floor; costs, the residual scale of
            the covariance and the symmetry tolerance never go below it.
        verdict: "accepted", "ambiguous" or "rejected"; reason: why, in words. With
            targets, the verdict is that of the worst target.
        targets: the per-target prediction of the targets passed to `match`, or None.
        points_used: data points the pose was refined on and its quality computed from.
        seed: the seed of every random choice of the search.
        acceptance: the thresholds the verdict used.
        extent: the model's extent (bounding box diagonal) [length units].
        seconds: wall time of the search; stage_seconds: per stage.
        search: the initial states and the minima they were refined to (SearchTrace).
    """

    T_model_data: Array
    rms: float
    inlier_fraction: float
    surface_fit: float
    sigma: float
    iterations: int
    converged: bool
    history: Array
    trajectory: Array
    mode: str
    starts: int
    best: Minimum
    second: Minimum | None
    rivals: tuple[Rival, ...]
    ambiguity: float
    covariance: Array
    worst_predicted_tre: float
    symmetries: tuple[Symmetry, ...]
    equivalent_poses: tuple[Array, ...]
    floor: float
    verdict: Verdict
    reason: str
    targets: TargetPrediction | None
    points_used: int
    seed: int
    acceptance: Acceptance
    extent: float
    fit_rejection: str | None
    seconds: float
    stage_seconds: dict[str, float] = field(default_factory=dict)
    search: SearchTrace | None = None

    @property
    def rotation(self) -> Array:
        """R (3, 3) of T_model_data."""
        return self.T_model_data[:3, :3]

    @property
    def translation(self) -> Array:
        """t (3,) of T_model_data."""
        return self.T_model_data[:3, 3]

    def predicted_tre(self, targets_model: Array) -> TargetPrediction:
        """Predicted TRE at targets (K, 3) in the model frame, and for each target whether a
        symmetry or a rival pose moves it, and its verdict."""
        targets = np.atleast_2d(np.asarray(targets_model, dtype=float))
        tre = predicted_tre(self.covariance, targets)
        return assess_targets(
            targets,
            tre,
            self.fit_rejection,
            self.symmetries,
            self.rivals,
            self.extent,
            self.acceptance,
        )
