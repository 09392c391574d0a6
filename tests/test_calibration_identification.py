"""The calibration's identification on synthetic readings, without a cell or a simulation:
the laser's lines on the spheres are made here from known errors (the arm's kinematic
deviations, the laser's mounting and range scale, the spheres 1 mm off their design) with the
arm's own kinematics (cell.robots), as the measurement would read them (the motors' joints,
the ranges along the laser's rays, seeded noise); the identification must find those errors
within what the noise lets it, and the check must fail for the nominal cell (the
identification skipped)."""

from __future__ import annotations

from functools import cached_property

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from threadpoolctl import threadpool_limits

from cell import LaserConfig, nominal_T_base_slot, nominal_T_base_table
from cell.robots import Robot, irb2400
from models.robot import LASER
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.calibration_identification import (
    CalibrationPriors,
    ParameterLayout,
    identify,
)
from scenarios.offline.calibration_measurement import (
    CalibrationPlan,
    SphereMeasurements,
    plan_views,
)

#: The laser's range noise per point [m] (its data sheet's figure, LaserConfig.sigma_m).
NOISE_M = 2.0e-5
#: The one table position the spheres are seen at [m].
TABLE_M = -0.25
#: How many posterior standard deviations an identified error may be off the true one.
TOLERANCE_SIGMAS = 4.0
PRIORS = CalibrationPriors(groups=("arm", "laser"), point_sigma_m=NOISE_M)


def _laser_frames(
    robot: Robot, dev: np.ndarray, mount: np.ndarray, q: np.ndarray, q_lock: np.ndarray
) -> np.ndarray:
    """(L, 4, 4) the laser's optical frame in the base frame at joints q (L, 6) on the arm
    with deviations `dev` (P,): the laser sits on the flange where the fetch at `q_lock`
    locked it (in its slot), off its drawing by `mount` (translation [m], rotation vector
    [rad])."""
    kin = robot.kinematics(dev)
    T_slot = nominal_T_base_slot(LASER.name)
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = Rotation.from_rotvec(mount[3:]).as_matrix(), mount[:3]
    T_flange_laser = np.linalg.inv(kin.fk(q_lock)) @ T_slot @ LASER.T_tool_tcp @ M
    return np.array([kin.fk(qk) @ T_flange_laser for qk in q])


class Cell:
    """The errors the readings are made with, and the readings."""

    def __init__(self, seed: int = 3) -> None:
        rng = np.random.default_rng(seed)
        robot = self.robot = irb2400()
        self.dev = robot.draw_deviations(rng, PRIORS.length_sigma_m, PRIORS.offset_sigma_rad)
        self.mount = rng.normal(0.0, 1.0, 6) * np.repeat(
            [PRIORS.laser_mount_sigma_m, PRIORS.laser_mount_sigma_rad], 3
        )
        self.scale = float(rng.normal(0.0, PRIORS.laser_scale_sigma))
        self.centres = DEFAULT_ARTIFACT.centres_table + rng.normal(0.0, 1e-3, (3, 3))
        T_table = nominal_T_base_table(TABLE_M)
        centres_base = self.centres @ T_table[:3, :3].T + T_table[:3, 3]
        # The views as the nominal arm plans them; the motors read their joints exactly.
        nominal = robot.kinematics().for_tool(LASER.name)
        plan = CalibrationPlan((TABLE_M,), views_per_sphere=16, seed=seed)
        views = plan_views(nominal, centres_base, plan, robot.q_home)
        q = np.array([v.q for v in views])
        q_lock = nominal.solve(nominal_T_base_slot(LASER.name), robot.q_home)
        # Each ray to the true sphere from the true laser frame, its range read with noise
        # and the true scale error.
        dirs = LaserConfig(n_rays=128).directions_tcp()
        frames = _laser_frames(robot, self.dev, self.mount, q, q_lock)
        radius = DEFAULT_ARTIFACT.radius_m
        line, sphere, points = [], [], []
        for k, (view, T) in enumerate(zip(views, frames, strict=True)):
            u = dirs @ T[:3, :3].T
            oc = T[:3, 3] - centres_base[view.sphere]
            b = u @ oc
            disc = b**2 - (oc @ oc - radius**2)
            hit = disc > 0.0
            ranges = -b[hit] - np.sqrt(disc[hit])
            read = (ranges + rng.normal(0.0, NOISE_M, len(ranges))) * (1.0 + self.scale)
            points.append(dirs[hit] * read[:, None])
            line.append(np.full(len(read), k))
            sphere.append(np.full(len(read), view.sphere))
        self.readings = SphereMeasurements(
            q, np.full(len(q), TABLE_M), np.zeros(len(q), dtype=int),
            np.concatenate(line), np.concatenate(sphere), np.concatenate(points), q_lock,
            nominal_T_base_slot(LASER.name), LASER.T_tool_tcp,
            DEFAULT_ARTIFACT.centres_table.copy(), radius, len(views),
        )  # fmt: skip

    def truth(self) -> np.ndarray:
        """The errors made: the arm's deviations (P,), the laser's mounting (6,) and scale,
        the spheres' centres (3 x 3, table frame)."""
        return np.concatenate([self.dev, self.mount, [self.scale], self.centres.ravel()])

    @cached_property
    def sigma(self) -> np.ndarray:
        """The posterior standard deviation of each error (as `truth`) that the noise and
        the priors allow: the linearized fit's covariance at the truth (the Jacobian by
        finite differences of the readings' rebuild; the centres without a prior)."""
        m, robot = self.readings, self.robot
        P = len(robot.parameters)
        T_table = nominal_T_base_table(TABLE_M)
        centres = self.centres @ T_table[:3, :3].T + T_table[:3, 3]

        def rebuilt(x: np.ndarray) -> np.ndarray:
            T = _laser_frames(robot, x[:P], x[P : P + 6], m.q_lines, m.q_lock)[m.line]
            p = m.p_laser / (1.0 + x[P + 6])
            return np.einsum("nij,nj->ni", T[:, :3, :3], p) + T[:, :3, 3]

        x0 = self.truth()[: P + 7]
        p0 = rebuilt(x0)
        d = p0 - centres[m.sphere]
        n = d / np.linalg.norm(d, axis=1)[:, None]
        prior = np.concatenate(
            [
                robot.sigmas(PRIORS.length_sigma_m, PRIORS.offset_sigma_rad),
                np.repeat([PRIORS.laser_mount_sigma_m, PRIORS.laser_mount_sigma_rad], 3),
                [PRIORS.laser_scale_sigma],
            ]
        )
        # The centres' columns in the base frame: the nominal table frame is not rotated.
        J = np.zeros((len(d), len(x0) + 9))
        for j in range(len(x0)):
            step = x0.copy()
            step[j] += 1e-3 * prior[j]
            J[:, j] = np.einsum("ni,ni->n", n, rebuilt(step) - p0) / (1e-3 * prior[j])
        for s in range(3):
            J[m.sphere == s, len(x0) + 3 * s : len(x0) + 3 * s + 3] = -n[m.sphere == s]
        info = J.T @ J / NOISE_M**2
        info[: len(x0), : len(x0)] += np.diag(1.0 / prior**2)
        return np.sqrt(np.diag(np.linalg.inv(info)))


@pytest.fixture(scope="module")
def cell() -> Cell:
    return Cell()


def _off(found: np.ndarray, cell: Cell) -> np.ndarray:
    """Which errors (as `Cell.truth`) `found` misses by more than TOLERANCE_SIGMAS of their
    posterior standard deviation."""
    return np.abs(found - cell.truth()) > TOLERANCE_SIGMAS * cell.sigma


def _identified(theta: np.ndarray, centres_table: np.ndarray, cell: Cell) -> np.ndarray:
    """The errors (as `Cell.truth`) in an identification's parameter vector and centres."""
    layout = ParameterLayout.of(cell.robot, PRIORS, cell.readings.stations)
    dev, _, mount, scale, _ = layout.unpack(theta)
    return np.concatenate([dev, mount, [scale], np.ravel(centres_table)])


def test_the_identification_finds_the_errors_the_readings_were_made_with(cell: Cell) -> None:
    """Every error within 4 posterior sigmas of the one made: with a 20 um laser noise on
    about 1,800 points, 0.02-0.07 mm on the arm's lengths and 0.005-0.07 mrad on its angles
    where the views tell them, the priors' 1 mm and 1 mrad where they do not (a flange
    offset the laser's mounting takes up); the points fit to the noise (its part along the
    spheres' normals), the nominal cell's to about 100 times that."""
    with threadpool_limits(1):  # small least squares: BLAS threads only contend
        fit = identify(cell.readings, cell.robot, PRIORS)
    found = _identified(fit.theta, fit.centres_table, cell)
    names = [*cell.robot.parameters, "mx", "my", "mz", "rx", "ry", "rz", "scale"]
    names += [f"sphere{s + 1} {a}" for s in range(3) for a in "xyz"]
    missed = [names[j] for j in np.flatnonzero(_off(found, cell))]
    assert not missed, f"errors not found: {missed}"
    assert 0.5 * NOISE_M < fit.residual_rms_after_m < NOISE_M
    assert fit.residual_rms_before_m > 50 * NOISE_M


def test_the_nominal_cell_fails_the_same_check(cell: Cell) -> None:
    """The check compares with the errors made, not with the code's output: the nominal
    cell (what an identification that does nothing would return) misses a dozen of them:
    those the views determine well, whose errors are far beyond what the noise allows."""
    layout = ParameterLayout.of(cell.robot, PRIORS, cell.readings.stations)
    nominal = _identified(layout.mean, DEFAULT_ARTIFACT.centres_table, cell)
    assert _off(nominal, cell).sum() >= 10
