"""The calibration's identification: the cell's model fitted to the laser points on the
spheres (`identify`), each group of parameters held by its data-sheet prior
(`CalibrationPriors`), and the cell model made of the fit (`cell_model`).

Every laser point is rebuilt from the measured joints, its range and ray and a candidate
parameter vector (`ParameterLayout`); its residual is its distance from its sphere's centre
minus the sphere's radius, the centres unknowns in the table frame. Gauss-Newton identifies
the parameters jointly with the centres (scenarios.offline.calibration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from cell import Kinematics
from cell.kinematics import payload_model
from cell.robots import Robot
from models.robot import LASER
from scenarios.offline.calibration_artifact import CalibrationError
from scenarios.offline.calibration_measurement import SphereMeasurements
from scenarios.offline.cell_model import CellModel, CompliantKinematics, TableModel

#: Finite-difference step of the numeric Jacobian, per prior sigma.
_STEP = 1e-3
#: The parameter groups a calibration can identify.
GROUPS: tuple[str, ...] = ("arm", "stiffness", "laser", "table")


@dataclass(frozen=True)
class CalibrationPriors:
    """What the data sheets say before the calibration, and which groups to identify.

    - `length_sigma_m`, `offset_sigma_rad`: the arm's kinematic parameters about the nominal.
    - `stiffness_nm_rad` (joints 2, 3), `stiffness_spread`: the arm maker's joint stiffness
      and its relative uncertainty.
    - `laser_mount_sigma_m`, `laser_mount_sigma_rad`: the laser's optical frame about its
      drawing's place on the tool plate; `laser_scale_sigma`: its range linearity.
    - `table_station_sigma_m`: where the table stops at each position beyond its readout
      (its repeatability and straightness), `table_angle_sigma_rad`: its guideway's pitch,
      roll and yaw along the travel.
    - `point_sigma_m`: the laser's range noise per point (its data sheet).
    - `groups`: what is identified (GROUPS); a group left out is not modelled (a rigid arm,
      the laser as drawn, a straight table).
    """

    length_sigma_m: float = 1.0e-3
    offset_sigma_rad: float = 1.0e-3
    stiffness_nm_rad: tuple[float, float] = (1.5e6, 1.0e6)
    stiffness_spread: float = 0.3
    laser_mount_sigma_m: float = 1.0e-3
    laser_mount_sigma_rad: float = 1.0e-2
    laser_scale_sigma: float = 1.0e-3
    table_station_sigma_m: float = 5.0e-5
    table_angle_sigma_rad: float = 1.0e-4
    point_sigma_m: float = 1.0e-4
    groups: tuple[str, ...] = GROUPS

    def __post_init__(self) -> None:
        unknown = sorted(set(self.groups) - set(GROUPS))
        if unknown or "arm" not in self.groups:
            raise CalibrationError(
                f"calibration groups {list(self.groups)}: valid are {list(GROUPS)}, and the arm "
                "is always identified"
            )
        sigmas = (
            self.length_sigma_m,
            self.offset_sigma_rad,
            self.stiffness_spread,
            self.laser_mount_sigma_m,
            self.laser_mount_sigma_rad,
            self.laser_scale_sigma,
            self.table_station_sigma_m,
            self.table_angle_sigma_rad,
            self.point_sigma_m,
            *self.stiffness_nm_rad,
        )
        if not all(np.isfinite(v) and v > 0.0 for v in sigmas):
            raise CalibrationError(f"calibration priors must be finite and > 0, got {self}")


#: The parts of a parameter vector: deviations, compliance, mounting, scale, table terms.
_Parts = tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]


@dataclass(frozen=True, eq=False)
class ParameterLayout:
    """The calibration's parameter vector: the arm's deviations (P), the compliance of
    joints 2 and 3 (2) [rad/(N m)], the laser's mounting (6: translation [m], rotation
    vector [rad]) and range scale (1), the table model's coefficients (12, row-major (6, 2):
    its translation terms are left to the stations, its rotation terms are the guideway's
    pitch, roll and yaw), and where the table stood at each station beyond its readout
    (3 per station [m], the first station the gauge: the spheres' centres take it up); each
    entry's prior mean and sigma, and which are free."""

    P: int
    stations: int
    mean: np.ndarray
    sigma: np.ndarray
    free: np.ndarray

    @classmethod
    def of(cls, robot: Robot, priors: CalibrationPriors, stations: int = 1) -> ParameterLayout:
        P = len(robot.parameters)
        k = np.asarray(priors.stiffness_nm_rad, dtype=float)
        compliance = 1.0 / k
        n = 3 * stations
        mean = np.concatenate([np.zeros(P), compliance, np.zeros(7), np.zeros(12), np.zeros(n)])
        table_sigma = np.repeat(
            [priors.table_station_sigma_m] * 3 + [priors.table_angle_sigma_rad] * 3, 2
        )
        sigma = np.concatenate(
            [
                robot.sigmas(priors.length_sigma_m, priors.offset_sigma_rad),
                compliance * priors.stiffness_spread,
                [priors.laser_mount_sigma_m] * 3 + [priors.laser_mount_sigma_rad] * 3,
                [priors.laser_scale_sigma],
                table_sigma,
                np.full(n, priors.table_station_sigma_m),
            ]
        )
        groups = set(priors.groups)
        table_free = np.repeat([False] * 3 + ["table" in groups] * 3, 2)
        free = np.concatenate(
            [
                np.asarray(robot.identified, dtype=bool),
                np.full(2, "stiffness" in groups),
                np.full(7, "laser" in groups),
                table_free,
                np.r_[np.zeros(3, dtype=bool), np.ones(n - 3, dtype=bool)],
            ]
        )
        if "stiffness" not in groups:
            mean[P : P + 2] = 0.0  # not modelled: a rigid arm
        return cls(P, stations, mean, sigma, free)

    @property
    def table_start(self) -> int:
        """Index of the first entry that moves the table frames, not the points."""
        return self.P + 9

    def unpack(self, theta: np.ndarray) -> _Parts:
        P = self.P
        return (
            theta[:P],
            theta[P : P + 2],
            theta[P + 2 : P + 8],
            float(theta[P + 8]),
            theta[P + 9 : P + 21].reshape(6, 2),
        )

    def station_offsets(self, theta: np.ndarray) -> np.ndarray:
        """(stations, 3) where the table stood at each station beyond its readout [m]."""
        return theta[self.P + 21 :].reshape(self.stations, 3)


def _mount(mount: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(mount[3:]).as_matrix()
    T[:3, 3] = mount[:3]
    return T


class _Model:
    """Evaluates the measured points and the spheres' centres in the base frame for a
    candidate parameter vector."""

    def __init__(self, m: SphereMeasurements, robot: Robot, layout: ParameterLayout) -> None:
        self.m, self.robot, self.layout = m, robot, layout
        self._arms: dict[bytes, Kinematics] = {}
        nominal = robot.kinematics()
        loaded = payload_model(nominal, LASER.name)
        bare = payload_model(nominal, None)
        data_l, data_b = loaded.createData(), bare.createData()
        self.g_lines = np.array(
            [pin.computeGeneralizedGravity(loaded, data_l, q) for q in m.q_lines]
        )
        self.g_lock = np.asarray(pin.computeGeneralizedGravity(bare, data_b, m.q_lock))

    def _kinematics(self, dev: np.ndarray) -> Kinematics:
        """The arm with deviations `dev`, built once per distinct vector (a Jacobian's
        columns other than the arm's own reuse the current arm)."""
        key = np.asarray(dev, dtype=float).tobytes()
        if key not in self._arms:
            if len(self._arms) > 32:
                self._arms.clear()
            self._arms[key] = self.robot.kinematics(dev)
        return self._arms[key]

    def points(self, theta: np.ndarray) -> np.ndarray:
        """(N, 3) the measured points in the base frame [m]."""
        m = self.m
        dev, compliance, mount, scale, _ = self.layout.unpack(theta)
        kin = self._kinematics(dev)
        c6 = np.zeros(6)
        c6[1:3] = compliance
        q_lock = m.q_lock - c6 * self.g_lock
        T_flange_laser = np.linalg.solve(kin.fk(q_lock), m.T_base_slot) @ m.T_tool_laser
        T_flange_laser = T_flange_laser @ _mount(mount)
        q_links = m.q_lines - c6 * self.g_lines
        T = np.array([kin.fk(q) @ T_flange_laser for q in q_links])[m.line]
        p = m.p_laser / (1.0 + scale)
        return np.einsum("nij,nj->ni", T[:, :3, :3], p) + T[:, :3, 3]

    def tables(self, theta: np.ndarray) -> np.ndarray:
        """(L, 4, 4) the table frame at each line's table position (its station's)."""
        table = TableModel(self.layout.unpack(theta)[4])
        offsets = self.layout.station_offsets(theta)
        out = table.T_base_tables(self.m.table_lines)
        out[:, :3, 3] += np.einsum("lij,lj->li", out[:, :3, :3], offsets[self.m.station_lines])
        return out


def _residuals(
    p: np.ndarray, T_tables: np.ndarray, centres: np.ndarray, m: SphereMeasurements
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residuals (N,), unit directions from the centres (N, 3) and each point's table
    rotation (N, 3, 3)."""
    T = T_tables[m.line]
    c = np.einsum("nij,nj->ni", T[:, :3, :3], centres[m.sphere]) + T[:, :3, 3]
    d = p - c
    norm = np.linalg.norm(d, axis=1)
    return norm - m.radius_m, d / norm[:, None], T[:, :3, :3]


def _fit(
    model: _Model,
    use: np.ndarray,
    theta: np.ndarray,
    centres: np.ndarray,
    free: np.ndarray,
    point_sigma_m: float,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Gauss-Newton on the points `use` (N,) bool: the spheres' centres (table frame) and the
    `free` (mask) entries of the parameter vector, each held by its prior."""
    m, layout = model.m, model.layout
    S = len(centres)
    theta, c = theta.copy(), centres.copy()
    idx = np.flatnonzero(free)
    sphere = m.sphere[use]
    done = 0
    for done in range(1, iterations + 1):  # noqa: B007 (the count is returned)
        p = model.points(theta)
        tables = model.tables(theta)
        res, n, R = _residuals(p, tables, c, m)
        res, n, R = res[use], n[use], R[use]
        J_c = np.zeros((len(res), 3 * S))
        nR = -np.einsum("ni,nij->nj", n, R)
        for k in range(S):
            J_c[sphere == k, 3 * k : 3 * k + 3] = nR[sphere == k]
        J_t = np.empty((len(res), len(idx)))
        for col, j in enumerate(idx):
            h = _STEP * layout.sigma[j]
            step = theta.copy()
            step[j] += h
            p_j = model.points(step) if j < layout.table_start else p
            t_j = model.tables(step) if j >= layout.table_start else tables
            r_j = _residuals(p_j, t_j, c, m)[0][use]
            J_t[:, col] = (r_j - res) / h * layout.sigma[j]  # per prior sigma
        z = (theta[idx] - layout.mean[idx]) / layout.sigma[idx]
        J = np.vstack(
            [
                np.hstack([J_t, J_c]) / point_sigma_m,
                np.hstack([np.eye(len(idx)), np.zeros((len(idx), 3 * S))]),
            ]
        )
        rvec = np.concatenate([res / point_sigma_m, z])
        delta = np.linalg.lstsq(J, -rvec, rcond=None)[0]
        theta[idx] = theta[idx] + delta[: len(idx)] * layout.sigma[idx]
        step_c = delta[len(idx) :].reshape(S, 3)
        c = c + step_c
        if np.max(np.abs(delta[: len(idx)]), initial=0.0) < 1e-6 and np.max(np.abs(step_c)) < 1e-9:
            break
    return theta, c, done


@dataclass(frozen=True, eq=False)
class Identification:
    """The fit: the parameter vector (see `ParameterLayout`), sphere centres (S, 3) in the table
    frame [m], point residual RMS with the data sheet's cell and with the identified one [m]
    (centres fitted for each), inlier points used, Gauss-Newton iterations of both fits."""

    theta: np.ndarray
    centres_table: np.ndarray
    residual_rms_before_m: float
    residual_rms_after_m: float
    points: int
    iterations: int
    fitted: FittedPoints | None = None


@dataclass(frozen=True, eq=False)
class FittedPoints:
    """Every measured point as the identified model places it, for a picture of the fit:
    its position (N, 3) in the table frame [m], its residual (N,) from its sphere with the
    identified model and with the data sheet's [m], whether the fit used it (N,), its
    sphere (N,) and its view (N,)."""

    points_table: np.ndarray
    residuals_m: np.ndarray
    residuals_before_m: np.ndarray
    used: np.ndarray
    sphere: np.ndarray
    view: np.ndarray


def identify(
    m: SphereMeasurements,
    robot: Robot,
    priors: CalibrationPriors | None = None,
    *,
    max_residual_rms_m: float = 1e-4,
    min_points_per_sphere: int = 200,
    iterations: int = 10,
) -> Identification:
    """Identify the cell's model (see the module's docstring) from the measurements, each
    group held by its data-sheet prior (`priors`). Points whose residual is beyond 4 robust
    sigmas (at least 0.3 mm) of a first fit are dropped. Raises CalibrationError for too few
    points on a sphere or a poor fit."""
    priors = priors or CalibrationPriors()
    S = len(m.centres_table)
    counts = np.bincount(m.sphere, minlength=S)
    if np.any(counts < min_points_per_sphere):
        raise CalibrationError(
            f"points per sphere {counts.tolist()}: each sphere needs at least "
            f"{min_points_per_sphere} laser points"
        )
    layout = ParameterLayout.of(robot, priors, m.stations)
    model = _Model(m, robot, layout)
    sigma_p = priors.point_sigma_m
    use = np.ones(m.points, dtype=bool)
    theta, c, its_first = _fit(
        model, use, layout.mean.copy(), m.centres_table, layout.free, sigma_p, iterations
    )
    res = _residuals(model.points(theta), model.tables(theta), c, m)[0]
    sigma = 1.4826 * float(np.median(np.abs(res - np.median(res))))
    use = np.abs(res) <= max(4.0 * sigma, 3e-4)
    counts = np.bincount(m.sphere[use], minlength=S)
    if np.any(counts < min_points_per_sphere):
        raise CalibrationError(
            f"inlier points per sphere {counts.tolist()} after the first fit: each sphere "
            f"needs at least {min_points_per_sphere}"
        )
    theta, c, its = _fit(model, use, theta, c, layout.free, sigma_p, iterations)
    p_base, tables = model.points(theta), model.tables(theta)
    all_after = _residuals(p_base, tables, c, m)[0]
    after = all_after[use]
    nominal = np.zeros_like(theta)
    _, c0, _ = _fit(model, use, nominal, c, np.zeros_like(layout.free), sigma_p, iterations)
    all_before = _residuals(model.points(nominal), model.tables(nominal), c0, m)[0]
    before = all_before[use]
    T = tables[m.line]
    in_table = np.einsum("nji,nj->ni", T[:, :3, :3], p_base - T[:, :3, 3])
    fitted = FittedPoints(in_table, all_after, all_before, use, m.sphere, m.line)
    rms_before = float(np.sqrt(np.mean(before**2)))
    rms_after = float(np.sqrt(np.mean(after**2)))
    if not rms_after <= max_residual_rms_m:
        raise CalibrationError(
            f"the calibration's residual RMS is {rms_after * 1e3:.3f} mm after the fit "
            f"({rms_before * 1e3:.3f} mm before), above the limit of "
            f"{max_residual_rms_m * 1e3:.3f} mm: the spheres or the views are not as planned"
        )
    return Identification(theta, c, rms_before, rms_after, int(use.sum()), its_first + its, fitted)


def cell_model(robot: Robot, fit: Identification, priors: CalibrationPriors) -> CellModel:
    """The cell's model from a fit: the arm (compliant if its stiffness was identified), the
    laser's mounting and scale, the table."""
    layout = ParameterLayout.of(robot, priors, (len(fit.theta) - len(robot.parameters) - 21) // 3)
    dev, compliance, mount, scale, table = layout.unpack(fit.theta)
    links = robot.kinematics(dev)
    kinematics: Kinematics = links
    if "stiffness" in priors.groups:
        kinematics = CompliantKinematics(links, compliance)
    return CellModel(kinematics, LASER.T_tool_tcp @ _mount(mount), scale, TableModel(table))
