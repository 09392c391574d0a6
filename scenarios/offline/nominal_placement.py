"""Where the planner believes an object sits on the table: its nominal pose."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.offline.settings import NominalPlacement


def resting_pose(R: np.ndarray, xy: np.ndarray, vertices: np.ndarray, lift_m: float) -> np.ndarray:
    """(4, 4) T_table_object with rotation R, origin at `xy` and the lowest vertex `lift_m`
    above the table top."""
    z = -float(np.min(np.asarray(vertices) @ R[2])) + lift_m
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [xy[0], xy[1], z]
    return T


def nominal_pose(placement: NominalPlacement, vertices_object: np.ndarray) -> np.ndarray:
    """(4, 4) the pose the planner believes: yaw about the table's vertical, resting on it."""
    R = Rotation.from_euler("z", placement.yaw_deg, degrees=True).as_matrix()
    return resting_pose(R, np.array(placement.xy_m), vertices_object, placement.lift_m)
