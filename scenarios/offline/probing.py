"""2D adjusting by IR edge probing (the seed paper's reference [1]): the IR sensor, looking
down, finds straight edges of a flat part by bisection on the height step, and two edges give
the part's position and heading on the table.

The part is assumed flat on the table (no tilt): that is the method's limit, and why 3D
surface matching replaces it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell import Controller, nominal_T_base_table
from models.targets import ProbeLine
from scenarios.program.tool_change import change_tool_safely
from scenarios.scenario_errors import ScenarioError

Progress = Callable[[str], None]
#: The IR sensor looks straight down (TCP z = -table z).
_R_DOWN = np.diag([1.0, -1.0, -1.0])


class EdgeNotFoundError(ScenarioError, LookupError):
    """The height step of an edge was not where the probe line searched for it."""


@dataclass(frozen=True)
class ProbeResult:
    """The edge points found (K, 3) in the nominal table frame, the estimated part pose
    T_table_object (4, 4), and the number of IR readings taken."""

    points_table: np.ndarray
    T_table_object: np.ndarray
    readings: int


def _T(p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = _R_DOWN
    T[:3, 3] = p
    return T


def find_edge(
    controller: Controller,
    p_inside_table: np.ndarray,
    p_outside_table: np.ndarray,
    height_m: float,
    step_m: float,
    resolution_m: float,
    coarse_step_m: float = 4e-3,
) -> tuple[np.ndarray, int]:
    """The edge between two points (3,) of the nominal table frame: a walk inwards from the
    outside point in steps of at most `coarse_step_m` to the first reading on the part, then
    bisection to `resolution_m`. The IR TCP is at `height_m` above the table top; a reading
    shorter than the table's by half of `step_m` is on the part. Returns the edge point (3,)
    (z = 0) and the readings taken."""
    readings = 0
    s = controller.table_position()
    T_base_table = nominal_T_base_table(s)
    T_table_base = np.linalg.inv(T_base_table)

    def probe(p: np.ndarray) -> tuple[bool, np.ndarray]:
        """Whether the IR sees the part at p, and where the sensor measured itself (3,)."""
        nonlocal readings
        target = T_base_table @ _T(np.array([p[0], p[1], height_m]))
        controller.move_linear(target, speed_m_s=0.1, settle_s=0.1)
        d = controller.read_ir()
        p_measured = (T_table_base @ controller.T_base_tcp())[:3, 3]
        readings += 1
        return d is not None and d < height_m - step_m / 2, p_measured

    start, end = np.asarray(p_inside_table, float), np.asarray(p_outside_table, float)
    # A coarse walk from the outside inwards to the first reading on the part: a start
    # point that falls into a hole of the part (its pose is unknown by up to the placement
    # range) is passed over, and the edge found is the outermost one.
    steps = max(1, int(np.ceil(np.linalg.norm(end - start) / coarse_step_m)))
    b, (outside, p_b) = end, probe(end)
    a = p_a = None
    for k in range(steps - 1, -1, -1):
        p = start + (end - start) * k / steps
        on, p_measured = probe(p)
        if on:
            a, p_a = p, p_measured
            break
        b, p_b = p, p_measured
    if outside or a is None or p_a is None:
        raise EdgeNotFoundError(
            f"no edge between [{start[0]:.4f}, {start[1]:.4f}] and [{end[0]:.4f}, "
            f"{end[1]:.4f}] m (table frame): the part is not where the probe line expects it"
        )
    while np.linalg.norm(b - a) > resolution_m:
        mid = (a + b) / 2
        on, p_mid = probe(mid)
        if on:
            a, p_a = mid, p_mid
        else:
            b, p_b = mid, p_mid
    # The edge lies between the last positions seen on and off the part, as measured by
    # the encoders (the commanded ones may differ by the servo's residual lag).
    edge = (p_a + p_b) / 2
    return np.array([edge[0], edge[1], 0.0]), readings


def pose_from_edges(
    probes: tuple[ProbeLine, ...], points_table: np.ndarray, z_m: float
) -> np.ndarray:
    """T_table_object (4, 4) of a flat part from edge points (K, 3): the heading from two
    points of the first edge (its probes 0 and 1), the position from every edge's offset."""
    p = np.asarray(points_table)[:, :2]
    d_part = probes[1].p_inside[:2] - probes[0].p_inside[:2]
    d_table = p[1] - p[0]
    yaw = np.arctan2(d_table[1], d_table[0]) - np.arctan2(d_part[1], d_part[0])
    c, s = np.cos(yaw), np.sin(yaw)
    R2 = np.array([[c, -s], [s, c]])
    # Each edge point x satisfies n . (R^T (x - t)) = offset, i.e. (R n) . t = (R n) . x - offset.
    A = np.array([R2 @ probe.normal[:2] for probe in probes])
    rhs = np.array([A[k] @ p[k] - probe.offset for k, probe in enumerate(probes)])
    t, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    T = np.eye(4)
    T[:2, :2] = R2
    T[:2, 3] = t
    T[2, 3] = z_m
    return T


def _first_edge_update(
    probes: tuple[ProbeLine, ...], points_table: np.ndarray, T_table_nominal: np.ndarray
) -> np.ndarray:
    """The nominal pose turned to the heading of the first edge and moved along its normal
    onto it (along the edge, the position stays nominal)."""
    p = points_table[:, :2]
    d_part = probes[1].p_inside[:2] - probes[0].p_inside[:2]
    d_table = p[1] - p[0]
    yaw = np.arctan2(d_table[1], d_table[0]) - np.arctan2(d_part[1], d_part[0])
    c, s = np.cos(yaw), np.sin(yaw)
    T = np.array(T_table_nominal, dtype=float)
    T[:2, :2] = np.array([[c, -s], [s, c]])
    n_table = T[:2, :2] @ probes[0].normal[:2]
    gap = n_table @ (p[0] - T[:2, 3]) - probes[0].offset
    T[:2, 3] += gap * n_table
    return T


def probe_part(
    controller: Controller,
    probes: tuple[ProbeLine, ...],
    T_table_nominal: np.ndarray,
    height_m: float,
    resolution_m: float = 1e-4,
    progress: Progress | None = None,
) -> ProbeResult:
    """Probe every edge with the IR sensor and estimate the part's pose on the table. The
    first two probes (one edge) are placed from the nominal pose `T_table_nominal`; the
    others from the pose corrected by that edge, as a 2D adjusting routine does."""
    say = progress or (lambda _msg: None)
    change_tool_safely(controller, "ir")
    T_guess = np.array(T_table_nominal, dtype=float)
    points, total = [], 0
    start = T_guess @ np.append(probes[0].p_inside, 1.0)
    above = nominal_T_base_table(controller.table_position()) @ _T(
        np.array([start[0], start[1], height_m + 0.05])
    )
    controller.move_tcp(above)
    for k, probe in enumerate(probes):
        R, t = T_guess[:3, :3], T_guess[:3, 3]
        p_in, p_out = R @ probe.p_inside + t, R @ probe.p_outside + t
        point, n = find_edge(controller, p_in, p_out, height_m, probe.step_m, resolution_m)
        points.append(point)
        total += n
        say(f"IR edge {probe.name}: found after {n} readings")
        if k == 1:  # the first edge's two points: heading and that edge's line are known
            T_guess = _first_edge_update(probes[:2], np.array(points), T_table_nominal)
    lifted = controller.T_base_tcp()
    lifted[2, 3] += 0.1
    controller.move_linear(lifted)
    points_table = np.array(points)
    z = float(T_table_nominal[2, 3])
    return ProbeResult(points_table, pose_from_edges(probes, points_table, z), total)
