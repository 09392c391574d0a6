"""Where an object sits on the table: its nominal pose and the real pose drawn around it."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.jobs.config import Placement


def _resting(R: np.ndarray, xy: np.ndarray, vertices: np.ndarray, lift_m: float) -> np.ndarray:
    """(4, 4) T_table_object with rotation R, origin at `xy` and the lowest vertex `lift_m`
    above the table top."""
    z = -float(np.min(np.asarray(vertices) @ R[2])) + lift_m
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [xy[0], xy[1], z]
    return T


def nominal_pose(placement: Placement, vertices_object: np.ndarray) -> np.ndarray:
    """(4, 4) the pose the planner believes: yaw about the table's vertical, resting on it."""
    R = Rotation.from_euler("z", placement.yaw_deg, degrees=True).as_matrix()
    return _resting(R, np.array(placement.xy_m), vertices_object, placement.lift_m)


def draw_true_pose(
    placement: Placement, vertices_object: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """(4, 4) a real pose: the nominal one moved uniformly within +-range_xy_m in x and y,
    turned within +-range_yaw_deg about the vertical and tilted within +-range_tilt_deg about
    a random horizontal axis, still resting on the table."""
    dxy = rng.uniform(-placement.range_xy_m, placement.range_xy_m, size=2)
    yaw = placement.yaw_deg + rng.uniform(-placement.range_yaw_deg, placement.range_yaw_deg)
    tilt = np.deg2rad(rng.uniform(-placement.range_tilt_deg, placement.range_tilt_deg))
    heading = rng.uniform(0.0, 2 * np.pi)
    axis = np.array([np.cos(heading), np.sin(heading), 0.0])
    R = (
        Rotation.from_rotvec(tilt * axis).as_matrix()
        @ Rotation.from_euler("z", yaw, degrees=True).as_matrix()
    )
    return _resting(R, np.array(placement.xy_m) + dxy, vertices_object, placement.lift_m)
