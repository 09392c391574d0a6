"""A quick check of a kept calibration: has the cell moved since it was made?

A real cell is checked between jobs in a few seconds (a BullsEye station, AccuBeam's
"Quick-Check") instead of calibrated anew. Here the laser views each reference sphere from a
few arm poses at one table position; the saved model places those points, and each sphere's
centre is fitted to them (its radius known) and compared with where the calibration found it.
A cell that drifted since (an arm warmed up, a joint's zero moved) puts the spheres off by
about what its tool is off: that shift, with its uncertainty, is the check's measurement.

The uncertainty is the views' own: each sphere's centre is fitted again leaving each view
out in turn (the jackknife), so that what the views share (the arm's pose repeatability, the
laser's noise) sets it, together with the calibration's own centres (their views' share of
that scatter). The check passes where the largest shift's 95 % upper bound is within the
tolerance; else the cell is to be calibrated anew. Where the object leaves fewer than three
views of a sphere clear, that sphere is not measured; with fewer than two spheres measured
the check cannot tell, and does not pass.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from cell import Controller
from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.calibration_artifact import SphereArtifact
from scenarios.offline.calibration_measurement import (
    CalibrationPlan,
    SphereMeasurements,
    measure_spheres,
)
from scenarios.results.calibration_check_result import DriftCheck

Clear = Callable[[np.ndarray, float], bool]
#: The 95th percentile of the length of a 3-D Gaussian vector of unit variance per axis (the
#: chi distribution with 3 degrees of freedom): a shift's length is bounded by its measured
#: length plus this many standard uncertainties.
CHI3_95 = 2.796
#: A sphere is measured from this many views or more (its centre and the jackknife's spread
#: need three), and the check from this many spheres or more.
MIN_VIEWS = 3
MIN_SPHERES = 2


def check_drift(
    controller: Controller,
    calibration: CalibrationResult,
    artifact: SphereArtifact,
    plan: CalibrationPlan,
    tolerance_m: float,
    clear: Clear | None = None,
) -> DriftCheck:
    """View the spheres as `plan` says (one table position, a few views a sphere) with the
    controller moving with `calibration`'s arm, and measure how far each sphere's centre has
    moved since `calibration` (see the module's docstring). The laser stays in hand, the arm
    at home."""
    if len(plan.table_positions_m) != 1:
        raise ValueError(f"a quick check views one table position, got {plan.table_positions_m}")
    t0 = time.perf_counter()
    # The laser stays in hand: the scan that follows uses it on the seat the check saw.
    m = measure_spheres(controller, artifact, plan, clear=clear, put_back=False)
    p_base = _points(m, calibration)
    T_base_table = calibration.model.T_base_table(float(m.table_lines[0]))
    was = calibration.centres_table @ T_base_table[:3, :3].T + T_base_table[:3, 3]
    shifts, variances = [], []
    for s in range(len(was)):
        on = m.sphere == s
        views = np.unique(m.line[on])
        if len(views) < MIN_VIEWS:
            continue  # not measured: the views the object left clear of it were too few
        centre = _centre(p_base[on], was[s], m.radius_m)
        leave_out = np.array(
            [_centre(p_base[on & (m.line != v)], centre, m.radius_m) for v in views]
        )
        k = len(views)
        jackknife = (k - 1) / k * np.sum((leave_out - leave_out.mean(axis=0)) ** 2, axis=0)
        calibrated_views = max(1, calibration.views // len(was))
        # the calibration's own centre carries its views' share of the same scatter
        variances.append(jackknife * (1.0 + k / calibrated_views))
        shifts.append(centre - was[s])
    shifts_m = np.array(shifts).reshape(-1, 3)
    seconds = time.perf_counter() - t0
    if len(shifts) < MIN_SPHERES:
        return DriftCheck(shifts_m, None, None, None, tolerance_m, False, m.views, len(p_base),
                          seconds)  # fmt: skip
    sigma = float(np.sqrt(np.mean(variances)))
    drift = float(np.max(np.linalg.norm(shifts_m, axis=1)))
    bound = drift + CHI3_95 * sigma
    return DriftCheck(
        shifts_m, sigma, drift, bound, tolerance_m, bound <= tolerance_m, m.views, len(p_base),
        seconds,
    )  # fmt: skip


def _points(m: SphereMeasurements, calibration: CalibrationResult) -> np.ndarray:
    """(N, 3) the measured points in the base frame as the calibrated model places them."""
    model = calibration.model
    T_lines = np.array([model.kinematics.fk(q) for q in m.q_lines])[m.line]
    ranges = np.linalg.norm(m.p_laser, axis=1)  # p_laser is a range times its unit ray
    p_tool = model.laser_points(ranges, m.p_laser / ranges[:, None])
    return np.einsum("nij,nj->ni", T_lines[:, :3, :3], p_tool) + T_lines[:, :3, 3]


def _centre(points: np.ndarray, start: np.ndarray, radius_m: float) -> np.ndarray:
    """The centre (3,) of the sphere of radius `radius_m` through `points` (N, 3), by
    Gauss-Newton from `start` (3,)."""
    c = np.asarray(start, dtype=float).copy()
    for _ in range(20):
        d = points - c
        norm = np.linalg.norm(d, axis=1)
        residual = norm - radius_m
        J = -d / norm[:, None]
        step = np.linalg.lstsq(J, -residual, rcond=None)[0]
        c += step
        if np.linalg.norm(step) < 1e-9:
            break
    return c
