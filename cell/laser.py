"""Laser readings to points, with the NOMINAL kinematics, as a real system computes them."""

from __future__ import annotations

import numpy as np

from cell.kinematics import Kinematics
from cell.readings import LaserReading


def laser_points_base(
    reading: LaserReading,
    kinematics: Kinematics,
    T_flange_laser: np.ndarray,
    directions_laser: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Points (M, 3) [m] in the robot base frame and their ray indices (M,).

    `T_flange_laser` (4, 4) the laser TCP in the flange frame, `directions_laser` (N, 3) the
    unit ray directions in the laser frame. Rays without a return give no point.
    """
    index = np.flatnonzero(reading.valid)
    T_base_laser = kinematics.fk(reading.q_measured) @ T_flange_laser
    p_laser = directions_laser[index] * reading.distances[index, None]
    return p_laser @ T_base_laser[:3, :3].T + T_base_laser[:3, 3], index


def points_in_table_frame(points_base: np.ndarray, T_base_table: np.ndarray) -> np.ndarray:
    """Points (M, 3) [m] from the robot base frame into the table frame, given the table's
    pose (4, 4) in the base frame (for a planner: `nominal_T_base_table(readout)`)."""
    R, p = T_base_table[:3, :3], T_base_table[:3, 3]
    return (np.asarray(points_base) - p) @ R
