"""The laser's latency identified on a calibration sphere: the laser swept straight across it
both ways at two speeds, one sphere's centre and the latency fitted to all four sweeps.

A laser that stamps its lines by its own clock (a line profiler across the network,
scenarios.irc5) hands each line over some time after its exposure: the camera's readout and
the profile's processing, plus what the clocks' offset, set while the arm stands, leaves out.
A line paired with the encoders of its stamp is then placed where the laser was `latency`
later: along the motion by speed times latency. Swept across a sphere, the sphere seems moved
forward by that much: the opposite way when swept back, twice as far at twice the speed. One
centre fits every sweep only with the right latency; a fixed error of the arm or the laser
moves the sphere the same way in every sweep and is the centre's, not the latency's.

Each point is moved back along the laser's own velocity at its line (from the encoders of the
lines around it), so a sweep need not be at its nominal speed where it crosses the sphere.
A point laser's sweeps cross the sphere along one great circle: they see the centre along the
sweep and in height, not across it, so the centre's coordinate across the sweeps stays at its
nominal (off by a millimetre, it changes the circle's radius by microns).
The sweeps run where the calibration ends, with the laser in hand at its last table position,
and only for a controller that pairs its lines by time (`Controller.laser_latency_s`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell import Controller, Kinematics, LaserReading, nominal_T_base_table
from models.robot import LASER
from scenarios.offline.calibration_artifact import CalibrationError, SphereArtifact
from scenarios.offline.calibration_measurement import Clear, path_clear, view_pose
from scenarios.offline.cell_model import CellModel
from scenarios.offline.laser_sheet import single_ray

#: The points along a sweep checked reachable and clear of the object.
SAMPLES_PER_SWEEP = 9
#: A sweep's lines kept for the fit: those with this many points on the sphere or more (a
#: point laser's: its one).
MIN_POINTS_PER_LINE = 5


@dataclass(frozen=True)
class LatencyPlan:
    """How the sphere is swept: the sweeps' speeds [m/s] (each forth and back), the laser's
    distance above the sphere's centre [m], how far each sweep runs beyond the sphere on
    either side [m] (its speed comes up before it reaches it), the lines' period [s]."""

    speeds_m_s: tuple[float, ...] = (0.1, 0.25)
    standoff_m: float = 0.22
    overrun_m: float = 0.04
    period_s: float = 0.01


@dataclass(frozen=True, eq=False)
class LatencySweeps:
    """The sweeps as measured: the sphere swept (index) and its nominal centre (3,) in the
    base frame [m], and each sweep's lines."""

    sphere: int
    centre_base: np.ndarray
    sweeps: tuple[tuple[LaserReading, ...], ...]


@dataclass(frozen=True)
class LatencyEstimate:
    """The laser's latency from exposure to stamp [s] and its standard uncertainty [s] (the
    lines taken as the independent samples, not the points: a line's points share its pose),
    from `points` points in `lines` lines of `sweeps` sweeps; the fit's residual RMS [m]."""

    latency_s: float
    sigma_s: float
    points: int
    lines: int
    sweeps: int
    residual_rms_m: float


def _sweep_ends(c: np.ndarray, plan: LatencyPlan, radius_m: float, roll: float) -> np.ndarray:
    """(2, 4, 4) the laser's poses at the ends of a sweep over the sphere centred at `c`:
    looking straight down, its fan across the sweep (the fan lies in the laser's x-z plane,
    the sweep runs along its y)."""
    T = view_pose(c, 0.0, 0.0, roll, plan.standoff_m)
    half = radius_m + plan.overrun_m
    ends = np.array([T.copy(), T.copy()])
    ends[0, :3, 3] -= half * T[:3, 1]
    ends[1, :3, 3] += half * T[:3, 1]
    return ends


def _sweep_joints(
    kin: Kinematics, ends: np.ndarray, q_seed: np.ndarray, clear: Clear | None, table_m: float
) -> np.ndarray | None:
    """(SAMPLES_PER_SWEEP, 6) joints along the sweep between `ends`, or None if a point of it
    has no IK solution or does not stand `clear` of the object."""
    q = np.asarray(q_seed, dtype=float)
    out = []
    for w in np.linspace(0.0, 1.0, SAMPLES_PER_SWEEP):
        T = ends[0].copy()
        T[:3, 3] = (1.0 - w) * ends[0, :3, 3] + w * ends[1, :3, 3]
        r = kin.ik(T, q, LASER.T_tool_tcp, extra_seeds=8)
        if not r.success or (clear is not None and not clear(r.q, table_m)):
            return None
        q = r.q
        out.append(q)
    return np.array(out)


def _ways_clear(
    clear: Clear | None, q_start: np.ndarray, q_now: np.ndarray, q_home: np.ndarray, table_m: float
) -> bool:
    """Whether the moves to a sweep's start `q_start` from where the arm stands and from it
    home stay `clear` of the object."""
    if clear is None:
        return True
    return path_clear(clear, q_now, q_start, table_m) and path_clear(
        clear, q_home, q_start, table_m
    )


def sweep_sphere(
    controller: Controller,
    centres_base: np.ndarray,
    radius_m: float,
    plan: LatencyPlan,
    clear: Clear | None = None,
) -> LatencySweeps:
    """Sweep the laser (in hand) across the highest sphere of `centres_base` (S, 3) [m] that
    a sweep reaches clear of the object, forth and back at each of the plan's speeds; the arm
    comes to the sweep by a joint move and ends at its start, both moves checked clear, as is
    the move home from there."""
    kin, table_m = controller.kinematics, controller.table_position()
    q_now = controller.read_joints()
    order = sorted(range(len(centres_base)), key=lambda s: -centres_base[s][2])  # highest first
    for s in order:
        for roll in (0.0, np.pi / 2):
            ends = _sweep_ends(centres_base[s], plan, radius_m, roll)
            q = _sweep_joints(kin, ends, q_now, clear, table_m)
            if q is None or not _ways_clear(clear, q[0], q_now, controller.q_home, table_m):
                continue
            controller.move_joints(q[0], settle_s=0.2)
            sweeps = []
            for speed in plan.speeds_m_s:
                for T in (ends[1], ends[0]):
                    sweeps.append(tuple(controller.scan_linear(T, speed, plan.period_s)))
            return LatencySweeps(s, np.asarray(centres_base[s], dtype=float), tuple(sweeps))
    raise CalibrationError(
        f"no sphere can be swept clear of the object (laser {plan.standoff_m * 1e3:.0f} mm above "
        f"its centre, {(radius_m + plan.overrun_m) * 2e3:.0f} mm long) to identify the laser's "
        "latency: set calibration.latency to the laser's latency from its data sheet [s]"
    )


def sweep_artifact(
    controller: Controller, artifact: SphereArtifact, plan: LatencyPlan, clear: Clear | None = None
) -> LatencySweeps:
    """`sweep_sphere` over the spheres of `artifact` at the table's position now (their
    nominal centres)."""
    T_base_table = nominal_T_base_table(controller.table_position())
    centres = artifact.centres_table @ T_base_table[:3, :3].T + T_base_table[:3, 3]
    return sweep_sphere(controller, centres, artifact.radius_m, plan, clear)


def _sweep_points(
    sweep: tuple[LaserReading, ...],
    model: CellModel,
    directions: np.ndarray,
    centre: np.ndarray,
    radius_m: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A sweep's points near the sphere (N, 3) [m], the laser's velocity at each (N, 3) [m/s]
    and each point's line (N,), all in the base frame."""
    if len(sweep) < 3:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=int)
    kin = model.kinematics
    T_tools = np.array([kin.fk(r.q_measured) for r in sweep])
    origins = (T_tools @ model.T_tool_laser)[:, :3, 3]
    times = np.array([r.time_s for r in sweep])
    velocity = np.gradient(origins, times, axis=0)
    points, speeds, line = [], [], []
    for k, r in enumerate(sweep):
        valid = r.valid
        p = model.laser_points(r.distances[valid], directions[valid])
        p = p @ T_tools[k, :3, :3].T + T_tools[k, :3, 3]
        rel = p - centre
        near = (np.linalg.norm(rel, axis=1) < radius_m + 0.005) & (rel[:, 2] > -0.5 * radius_m)
        if np.count_nonzero(near) >= min(MIN_POINTS_PER_LINE, len(directions)):
            points.append(p[near])
            speeds.append(np.repeat(velocity[k][None], np.count_nonzero(near), axis=0))
            line.append(np.full(np.count_nonzero(near), k))
    if not points:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=int)
    return np.concatenate(points), np.concatenate(speeds), np.concatenate(line)


def _fit(
    p: np.ndarray,
    v: np.ndarray,
    centre: np.ndarray,
    radius_m: float,
    keep: np.ndarray,
    basis: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gauss-Newton for the centre (moved from `centre` (3,) along the columns of `basis`
    (3, k) only) and the latency's correction (the points moved back along their velocity by
    it) over the points `keep`: (x (4,): the centre and the correction, residuals (N,) of
    all points, J^T J (k + 1, k + 1), the last row and column the latency's)."""
    c, dt = np.asarray(centre, dtype=float).copy(), 0.0
    JtJ = np.eye(basis.shape[1] + 1)
    for _ in range(20):
        q = p - v * dt
        rel = q - c
        dist = np.linalg.norm(rel, axis=1)
        u = rel / dist[:, None]
        r = dist - radius_m
        J = np.column_stack([-u @ basis, -np.einsum("ij,ij->i", u, v)])
        JtJ = J[keep].T @ J[keep]
        step = np.linalg.solve(JtJ, -J[keep].T @ r[keep])
        c, dt = c + basis @ step[:-1], dt + float(step[-1])
        if np.max(np.abs(step[:-1])) < 1e-9 and abs(step[-1]) < 1e-7:
            break
    q = p - v * dt
    return np.append(c, dt), np.linalg.norm(q - c, axis=1) - radius_m, JtJ


def _centre_basis(v: np.ndarray, single_ray: bool) -> np.ndarray:
    """The directions (3, k) the sphere's centre is fitted along: all three for a line laser;
    for a point laser, along the sweeps (the principal axis of `v` (N, 3), the points'
    velocities: the sweeps run forth and back along one level line) and the height across
    them, not across the sweeps."""
    if not single_ray:
        return np.eye(3)
    along = np.linalg.eigh(v.T @ v)[1][:, -1]  # forth and back: the axis of travel
    across = np.cross(along, [0.0, 0.0, 1.0])
    across = across / np.linalg.norm(across)
    return np.column_stack([along, np.cross(across, along)])


def identify_latency(
    measured: LatencySweeps,
    model: CellModel,
    directions_tcp: np.ndarray,
    radius_m: float,
    latency_paired_s: float,
) -> LatencyEstimate:
    """The laser's latency from the sweeps (their lines paired with the encoders
    `latency_paired_s` [s] before their stamps), with the cell's `model` placing the points:
    the sphere's centre and the latency's correction fitted to every sweep's points at once,
    points beyond 3.5 robust sigmas of the residuals left out (twice refitted)."""
    parts = [
        _sweep_points(sweep, model, directions_tcp, measured.centre_base, radius_m)
        for sweep in measured.sweeps
    ]
    p = np.concatenate([part[0] for part in parts])
    v = np.concatenate([part[1] for part in parts])
    # each point's (sweep, line): the lines are the independent samples
    line = np.concatenate(
        [np.column_stack([np.full(len(part[2]), k), part[2]]) for k, part in enumerate(parts)]
    )
    used = sum(1 for part in parts if len(part[0]))
    if used < 2 or len(p) < 50:
        raise CalibrationError(
            f"the latency sweeps over sphere {measured.sphere + 1} saw it in {used} of "
            f"{len(parts)} sweeps ({len(p)} points): is the laser's stream coming while the arm "
            "moves?"
        )
    basis = _centre_basis(v, single_ray(directions_tcp))
    keep = np.ones(len(p), dtype=bool)
    x, r, JtJ = _fit(p, v, measured.centre_base, radius_m, keep, basis)
    for _ in range(2):
        scale = 1.4826 * float(np.median(np.abs(r - np.median(r))))
        keep = np.abs(r) <= 3.5 * max(scale, 1e-6)
        x, r, JtJ = _fit(p, v, x[:3], radius_m, keep, basis)
    n, lines = int(np.count_nonzero(keep)), len(np.unique(line[keep], axis=0))
    rms = float(np.sqrt(np.mean(r[keep] ** 2)))
    cov = np.linalg.inv(JtJ) * rms**2 * (n / max(lines, 1))
    return LatencyEstimate(
        latency_s=float(latency_paired_s + x[3]),
        sigma_s=float(np.sqrt(cov[-1, -1])),
        points=n,
        lines=lines,
        sweeps=used,
        residual_rms_m=rms,
    )


def latency_alone(
    controller: Controller,
    artifact: SphereArtifact,
    table_m: float,
    plan: LatencyPlan | None = None,
    clear: Clear | None = None,
) -> LatencyEstimate:
    """The laser's latency without calibrating the arm (a laser changed, say): the laser
    fetched, the table at `table_m` [m], a sphere of `artifact` swept as `plan` says, the
    points placed by the controller's arm and the laser's drawing; the laser back in its
    slot. The arm's own errors move the sphere alike in every sweep: they leave the latency
    as it is."""
    plan = plan or LatencyPlan()
    controller.move_joints(controller.q_home)
    controller.change_tool(LASER.name)
    controller.move_table(table_m)
    paired_s = controller.laser_latency_s or 0.0
    sweeps = sweep_artifact(controller, artifact, plan, clear)
    controller.move_joints(controller.q_home)
    controller.return_tool()
    model = CellModel.nominal(controller.kinematics)
    directions = controller.laser_directions_tcp
    return identify_latency(sweeps, model, directions, artifact.radius_m, paired_s)
