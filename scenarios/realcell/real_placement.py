"""Where an object really sits on the table: a pose drawn around the nominal one."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.configuration.cell_sections import Placement
from scenarios.offline.nominal_placement import resting_pose, yawed_rotation


def draw_true_pose(
    placement: Placement, vertices_object: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """(4, 4) a real pose: the nominal one (its up axis, roll and pitch as the planner
    believes them) moved uniformly within +-range_xy_m in x and y, turned within
    +-range_yaw_deg about the vertical and tilted within +-range_tilt_deg about a random
    horizontal axis of the table, still resting on the table."""
    dxy = rng.uniform(-placement.range_xy_m, placement.range_xy_m, size=2)
    yaw = placement.yaw_deg + rng.uniform(-placement.range_yaw_deg, placement.range_yaw_deg)
    tilt = np.deg2rad(rng.uniform(-placement.range_tilt_deg, placement.range_tilt_deg))
    heading = rng.uniform(0.0, 2 * np.pi)
    axis = np.array([np.cos(heading), np.sin(heading), 0.0])
    R = Rotation.from_rotvec(tilt * axis).as_matrix() @ yawed_rotation(placement, yaw)
    return resting_pose(R, np.array(placement.xy_m) + dxy, vertices_object, placement.lift_m)
