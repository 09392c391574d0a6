"""Global and local surface matching behind one call: `match(data, model, ...)`.

The steps, coarse to fine:
1. the search (search.py): initial states for the mode, all scored at once, the best
   refined together, the distinct survivors kept (plus the caller's guess, if any);
2. each candidate refined by ICP on a subsample of the data, and the minima ranked and the
   two best judged against each other (judge.py); a minimum that differs from the best by a
   symmetry of the model (symmetry.py) is the same pose, not a rival;
3. the best refined to convergence on the points used (fast closest points first, the
   exact operator last), and its quality computed: the residuals, the covariance and the
   predicted TRE (quality.py), and the verdict for the model or for each target
   (verdict.py).

Every random choice is drawn from one seed: the same data, model and seed give the same
result, bit for bit.

Here are `match` and the steps run in order; the inputs are checked in match_request.py and
the points worked on drawn in match_work.py, step 2 is minima.py and step 3's quality and
verdict assessment.py.
"""

from __future__ import annotations

import time

import numpy as np

from registration.assessment import assess
from registration.icp import IcpResult, Variant, icp
from registration.kernels import Kernel
from registration.match_request import (
    MatchRequest,
    Mode,
    Progress,
    as_shape,
    check_options,
    check_units,
)
from registration.match_work import MatchWork, draw_work
from registration.minima import Judged, find_minima, judge_minima
from registration.quality import ScanPasses
from registration.result import MatchResult, Minimum, SearchTrace
from registration.rigid import Array
from registration.search import Found, SearchSettings
from registration.shapes.base import Shape
from registration.verdict import Acceptance


# A library entry point: its options are keyword-only, each with its default (see the
# docstring); a settings object would only move them.
def match(  # noqa: PLR0913
    data: Array,
    model: Shape | Array | object,
    *,
    mode: Mode = "auto",
    T_init: Array | None = None,
    targets: Array | None = None,
    noise: float | None = None,
    seed: int = 0,
    variant: Variant = "point_to_plane",
    kernel: Kernel | None = None,
    acceptance: Acceptance | None = None,
    settings: SearchSettings | None = None,
    max_iterations: int = 60,
    progress: Progress | None = None,
    passes: ScanPasses | None = None,
) -> MatchResult:
    """Register data points to a model surface and judge the result.

    Args:
        data: measured points (N, 3) in the data (sensor or robot) frame.
        model: the virtual model: a Shape, an (M, 3) point array, or a mesh object.
        mode: "auto" (default: any coverage, from a small patch to the whole surface),
            "global" (the data cover the whole surface, eq. 9), "local" (part of it, eq. 10)
            or "refine" (ICP from T_init only: no search, so no rival is looked for).
        T_init: a guess of T_model_data (4, 4); the start of "refine", one more candidate
            in the other modes.
        targets: points (K, 3) in the model frame that the pose must locate (an operation's
            targets); the verdict is then that of the worst target, and a symmetry or a
            rival pose that leaves every target in place does not make it ambiguous.
        noise: standard deviation of the sensor's range noise [length units], if known: the
            floor of the residual scale (costs, covariance, symmetry tolerance).
        seed: seed of every random choice (subsamples); same data and seed, same result.
        variant: "point_to_plane" (default when the model has normals) or "point_to_point".
        kernel: the robust kernel of every ICP stage (the vectorised search, the ranking and
            the refinement) and of the covariance's weights; Tukey(c=8) with the floor as
            its scale's floor by default. The inlier fraction and the judging of minima
            keep Tukey's cut-off as their yardstick.
        acceptance: thresholds of the verdict.
        settings: sizes of the coarse-to-fine search.
        max_iterations: ICP iteration cap of the final refinement.
        progress: optional callable receiving one line per stage.
        passes: which scan pass each data point came from and the standard deviation of a
            pass's rigid offset (the arm's accuracy); widens the covariance accordingly.

    Returns:
        A MatchResult; poor or ambiguous matches are reported in `verdict`, not raised.
    """
    t_start = time.perf_counter()
    data, T_init, targets = check_options(data, mode, T_init, targets, noise, seed, passes)
    shape = as_shape(model)
    check_units(data, shape)
    return _match(
        MatchRequest(
            data=data,
            shape=shape,
            mode=mode,
            T_init=T_init,
            targets=targets,
            noise=noise,
            seed=int(seed),
            variant=variant,
            kernel=kernel,
            acceptance=acceptance or Acceptance(),
            settings=settings or SearchSettings(),
            max_iterations=max_iterations,
            say=progress or (lambda _msg: None),
            passes=passes,
            t_start=t_start,
        )
    )


def _refine(
    request: MatchRequest, w: MatchWork, judged: Judged, stage: dict[str, float]
) -> tuple[IcpResult, Array, Minimum]:
    """The best minimum refined on `w.fit` with the exact operator (its poses appended to
    `judged.trajectory`): the run, the RMS per iteration of both refinements [length units]
    and the best minimum."""
    t0 = time.perf_counter()
    fine_run = icp(w.fit, w.shape, judged.coarse.T_model_data, variant=request.variant,
                   kernel=w.kernel, max_iterations=min(3, request.max_iterations),
                   callback=lambda _k, T, _m: judged.trajectory.append(T.copy()),
                   closest=w.exact)  # fmt: skip
    history = np.sqrt(np.concatenate([judged.coarse.mse_history, fine_run.mse_history]))
    best = Minimum(fine_run.T_model_data, judged.best_cost)
    stage["refine"] = time.perf_counter() - t0
    return fine_run, history, best


def _match(request: MatchRequest) -> MatchResult:
    """The match the request asks for, step by step (see the module's docstring)."""
    stage: dict[str, float] = {}
    rng = np.random.default_rng(request.seed)
    w = draw_work(request, rng)
    minima = find_minima(request, w, rng, stage)
    judged = judge_minima(request, w, minima.runs, stage)
    fine_run, history, best = _refine(request, w, judged, stage)
    request.say(f"ranked {len(minima.runs)} minima; the best refined on {len(w.fit)} points")
    assessment = assess(request, w, best.T_model_data, judged, stage)
    q = assessment.quality
    turns = tuple(s.motion() @ best.T_model_data for s in judged.symmetries if s.kind == "turn")
    request.say(f"{assessment.verdict}: {assessment.reason}")
    return MatchResult(
        T_model_data=best.T_model_data,
        rms=q.rms,
        inlier_fraction=q.inlier_fraction,
        surface_fit=q.surface_fit,
        sigma=q.sigma,
        iterations=len(history),
        converged=fine_run.converged,
        history=history,
        trajectory=np.asarray(judged.trajectory),
        mode=request.mode,
        starts=minima.starts,
        best=best,
        second=judged.second,
        rivals=judged.rivals,
        ambiguity=float(judged.ambiguity),
        covariance=q.covariance,
        worst_predicted_tre=q.worst_tre,
        symmetries=judged.symmetries,
        equivalent_poses=turns,
        floor=float(w.floor),
        verdict=assessment.verdict,
        reason=assessment.reason,
        targets=assessment.targets,
        points_used=len(w.work),
        seed=request.seed,
        acceptance=request.acceptance,
        extent=w.shape.extent,
        fit_rejection=assessment.fit_rejection,
        seconds=time.perf_counter() - request.t_start,
        stage_seconds=stage,
        search=_trace(
            minima.traces, minima.candidates, minima.runs[judged.best_index].T_model_data
        ),
    )


def _trace(traces: list[Found], candidates: list[Array], T_best: Array) -> SearchTrace:
    """The search's trace (one or two searches, or a refinement's single start)."""
    if not traces:
        start = np.asarray(candidates)
        return SearchTrace(start, np.zeros(len(start)), start, np.zeros(len(start)), T_best)
    return SearchTrace(
        np.concatenate([f.start_poses for f in traces]),
        np.concatenate([f.start_costs for f in traces]),
        np.concatenate([f.minima for f in traces]),
        np.concatenate([f.minima_costs for f in traces]),
        T_best,
    )
