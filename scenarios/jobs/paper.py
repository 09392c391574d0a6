"""The seed paper's experiments (section 3): an ellipsoid's 55 model points matched with
data sets of different sizes and noise, globally and locally, and with its analytic surface.

Noise follows the paper: a Gaussian of variance 1/20 of the largest absolute coordinate of
the points (lengths read in millimetres, see models.ellipsoid), three times that in test 4.
Generation and evaluation read the true pose; the matching does not.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from models import ellipsoid
from models.atomic import write_atomic
from registration import (
    Acceptance,
    MatchResult,
    ParametricModel,
    PointModel,
    Shape,
    match,
    pose_error,
    transform_points,
)
from registration.icp import icp
from registration.quality import trimmed_rms
from registration.rigid import Array, invert, random_transform
from scenarios.results.json_converter import register_writer


@dataclass(frozen=True)
class PaperTest:
    """One experiment: data size, noise (multiple of the paper's variance), mode, model."""

    number: int
    title: str
    n_data: int
    noise_factor: float
    mode: Literal["global", "local"]
    model: Literal["points", "surface"]


TESTS: tuple[PaperTest, ...] = (
    PaperTest(1, "global, no noise", 55, 0.0, "global", "points"),
    PaperTest(2, "global, noise", 55, 1.0, "global", "points"),
    PaperTest(3, "local 24 of 55, noise", 24, 1.0, "local", "points"),
    PaperTest(4, "local 15 of 55, 3x variance", 15, 3.0, "local", "points"),
    PaperTest(5, "analytic surface, noise", 55, 1.0, "global", "surface"),
)


@dataclass(frozen=True)
class PaperRow:
    """Result of one experiment, evaluated against the true pose.

    Attributes:
        rotation_error_deg: for the analytic surface, up to the ellipsoid's symmetry (a
            symmetric surface cannot tell its four symmetric poses apart).
        global_minimum: the search's minimum is at least as good as ICP started at the true
            pose (same data, same cost): the search did not stop in a local minimum.
    """

    test: int
    title: str
    n_data: int
    n_model: int
    noise_sigma_m: float
    starts: int
    rms_m: float
    rotation_error_deg: float
    translation_error_m: float
    ambiguity: float
    verdict: str
    global_minimum: bool
    seconds: float


@dataclass(frozen=True)
class PaperCase:
    """Inputs and outputs of one experiment, for plots."""

    test: PaperTest
    data: Array
    model_points: Array
    result: MatchResult
    row: PaperRow


def noise_sigma(points: Array, factor: float) -> float:
    """Sigma [m] of the paper's noise: variance = factor * max |coordinate| / 20, in mm."""
    variance_mm2 = factor * float(np.abs(points).max()) * 1e3 / 20.0
    return float(np.sqrt(variance_mm2)) * 1e-3


def _data_points(test: PaperTest, X: Array, rng: np.random.Generator) -> Array:
    if test.model == "surface":
        return ellipsoid.sample_surface(test.n_data, seed=int(rng.integers(1 << 31)))
    if test.n_data >= len(X):
        return X.copy()
    # Local matching: the data cover one part of the surface, around a random model point.
    center = X[rng.integers(len(X))]
    return X[np.argsort(np.linalg.norm(X - center, axis=1))[: test.n_data]]


def _rotation_error(T: Array, T_truth: Array, symmetric: bool) -> tuple[float, float]:
    errors = []
    for S in ellipsoid.symmetry_rotations() if symmetric else [np.eye(3)]:
        T_sym = np.eye(4)
        T_sym[:3, :3] = S
        errors.append(pose_error(T_sym @ T, T_truth))
    return min(errors)


def run_test(test: PaperTest, seed: int) -> PaperCase:
    """Generate the data of one experiment, match them, and evaluate against the truth."""
    rng = np.random.default_rng([seed, test.number])
    X = ellipsoid.model_points()
    shape: Shape = (
        PointModel(X)
        if test.model == "points"
        else ParametricModel(
            ellipsoid.surface_point, ellipsoid.U_RANGE, ellipsoid.V_RANGE, periodic_u=True
        )
    )
    clean = _data_points(test, X, rng)
    sigma = noise_sigma(clean, test.noise_factor)
    noisy = clean + rng.normal(scale=sigma, size=clean.shape) if sigma > 0 else clean
    T_data_model = random_transform(rng, translation_scale=0.1)
    data = transform_points(T_data_model, noisy)
    T_truth = invert(T_data_model)

    t0 = time.perf_counter()
    # The sensor's noise is part of the setup (a data sheet figure, not the hidden truth):
    # a fit is acceptable up to three times the RMS distance that noise alone produces.
    acceptance = Acceptance(max_rms=3.0 * sigma * np.sqrt(3.0)) if sigma > 0 else None
    result = match(data, shape, mode=test.mode, acceptance=acceptance)
    seconds = time.perf_counter() - t0

    rot, trans = _rotation_error(result.T_model_data, T_truth, test.model == "surface")
    # The same robust ICP started at the true pose: the cost the search must at least reach.
    truth_run = icp(data, shape, T_truth)
    found_run = icp(data, shape, result.T_model_data)
    trim = 0.7
    found_cost = float(trimmed_rms(found_run.residuals, trim))
    truth_cost = float(trimmed_rms(truth_run.residuals, trim))
    global_minimum = found_cost <= truth_cost * 1.001 + 1e-9 * shape.extent
    row = PaperRow(
        test=test.number,
        title=test.title,
        n_data=len(data),
        n_model=len(X) if test.model == "points" else 0,
        noise_sigma_m=sigma,
        starts=result.starts,
        rms_m=result.rms,
        rotation_error_deg=float(np.degrees(rot)),
        translation_error_m=trans,
        ambiguity=result.ambiguity,
        verdict=result.verdict,
        global_minimum=global_minimum,
        seconds=seconds,
    )
    return PaperCase(test, data, X, result, row)


def run_paper(seed: int = 0, progress: Callable[[str], None] | None = None) -> list[PaperCase]:
    """Run the five experiments with one seed."""
    cases = []
    for test in TESTS:
        if progress:
            progress(f"test {test.number}: {test.title}")
        cases.append(run_test(test, seed))
    return cases


def table_text(rows: list[PaperRow]) -> str:
    """The results as a plain-text table (lengths in mm)."""
    head = (
        f"{'test':>4}  {'':28s} {'N data':>6} {'N model':>7} {'noise mm':>8} {'starts':>6} "
        f"{'rms mm':>7} {'rot err deg':>11} {'trans err mm':>12} {'ambig':>5} "
        f"{'global min':>10}  verdict"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r.test:>4}  {r.title:28s} {r.n_data:>6} {r.n_model or 'surf':>7} "
            f"{r.noise_sigma_m * 1e3:>8.2f} {r.starts:>6} {r.rms_m * 1e3:>7.2f} "
            f"{r.rotation_error_deg:>11.2f} {r.translation_error_m * 1e3:>12.2f} "
            f"{r.ambiguity:>5.2f} {'yes' if r.global_minimum else 'NO':>10}  {r.verdict}"
        )
    lines.append(
        "Test 5 rotation error is up to the ellipsoid's symmetry (its four 180-degree poses fit "
        "the analytic surface equally, hence 'ambiguous'). 'global min': the search's minimum "
        "is at least as good as ICP started at the true pose."
    )
    return "\n".join(lines) + "\n"


def plot_cases(cases: list[PaperCase], path: str) -> None:
    """Before/after figure of every experiment, like the paper's figures 1-9, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(4 * len(cases), 8))
    for k, case in enumerate(cases):
        u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.linspace(0, np.pi, 20))
        wire = ellipsoid.surface_point(u, v) * 1e3
        registered = transform_points(case.result.T_model_data, case.data) * 1e3
        for row, (pts, label) in enumerate(
            ((case.data * 1e3, "before"), (registered, "after matching"))
        ):
            ax = fig.add_subplot(2, len(cases), row * len(cases) + k + 1, projection="3d")
            if case.test.model == "surface":
                ax.plot_wireframe(*wire.transpose(2, 0, 1), color="0.75", linewidth=0.4)
            else:
                m = case.model_points * 1e3
                ax.scatter(*m.T, s=10, c="tab:blue", label="model X")
            ax.scatter(*pts.T, s=14, c="tab:red", marker="^", label="data P")
            ax.set_title(f"test {case.test.number}: {label}", fontsize=9)
            ax.set_xlabel("x mm", fontsize=7)
            ax.set_ylabel("y mm", fontsize=7)
            ax.set_zlabel("z mm", fontsize=7)
            ax.tick_params(labelsize=6)
            ax.set_aspect("equal")
            if k == 0 and row == 0:
                ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(f"Seed paper experiments: ellipsoid {ellipsoid.RADII} m, 55 model points")
    fig.tight_layout()
    write_atomic(Path(path), lambda tmp: fig.savefig(tmp, dpi=90, format="png"))
    plt.close(fig)


@dataclass(frozen=True)
class PaperResult:
    """The paper's experiments as a run's result: the tests, their rows and the table; the
    run's wall time [s] (set by the runner)."""

    job: str
    seed: int
    rows: tuple[PaperRow, ...]
    tests: tuple[PaperTest, ...] = TESTS
    seconds: float | None = None

    @property
    def status(self) -> str:
        return "complete"

    @property
    def table(self) -> str:
        return table_text(list(self.rows))


register_writer(
    PaperResult,
    keys="status reason job seed tests rows table seconds",
    derived=lambda p: {"status": p.status, "reason": "", "table": p.table},
)
